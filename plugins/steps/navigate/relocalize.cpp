#include <stdexcept>

#include "navigate.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/navigation/localizer.hpp"

namespace projtour::navigate {

Relocalize::Relocalize(const Params& params, const RunContext&)
    : widen_m_(params.number(param::kWidenM)),
      spin_rate_radps_(deg_to_rad(params.number(param::kSpinRateDps))),
      give_up_s_(params.number(param::kGiveUpS)),
      settle_s_(params.number(param::kSettleS)),
      converged_std_m_(params.number(param::kConvergedStdM)) {}

void Relocalize::start(Context& ctx) {
  if (!ctx.drivers().base) throw std::runtime_error("relocalize needs a base driver");
  if (ctx.drivers().projector) ctx.drivers().projector->blank();
  ctx.blackboard().set(keys::kLocalizationWiden, widen_m_);
  start_s_ = ctx.state_elapsed_s();  // pauses count neither as spinning nor as settling
  converged_since_s_ = -1.0;
}

std::optional<Outcome> Relocalize::tick(Context& ctx) {
  BaseDriver& base = *ctx.drivers().base;
  if (ctx.cancel_requested()) {
    base.command_velocity(0, 0);
    return Outcome{kOutcomeCancelled, "cancelled"};
  }
  const double now_s = ctx.state_elapsed_s();
  const PoseEstimate2D* estimate = ctx.blackboard().find(keys::kLocalization);
  const bool widened = !ctx.blackboard().has(keys::kLocalizationWiden);  // the service took it
  const bool* service_converged = ctx.blackboard().find(keys::kLocalizationConverged);
  const bool converged = widened && estimate &&
                         navigation::position_std_m(*estimate) < converged_std_m_ &&
                         service_converged != nullptr && *service_converged;
  if (!converged) {
    converged_since_s_ = -1.0;
  } else if (converged_since_s_ < 0.0) {
    converged_since_s_ = now_s;
  }
  // Converged for a while, with the laser having swept the surroundings while it held.
  if (converged_since_s_ >= 0.0 && now_s - converged_since_s_ >= settle_s_) {
    base.command_velocity(0, 0);
    return Outcome{outcome::kSucceeded, ""};
  }
  if (now_s - start_s_ > give_up_s_) {
    base.command_velocity(0, 0);
    return Outcome{outcome::kLost, "localization did not converge within " +
                                       std::to_string(give_up_s_) + " s of spinning"};
  }
  base.command_velocity(0, spin_rate_radps_);
  return std::nullopt;
}

void Relocalize::stop(Context& ctx) {
  if (ctx.drivers().base) ctx.drivers().base->command_velocity(0, 0);
}

}  // namespace projtour::navigate
