// next: leave the target safely, projector blank and head stowed. Which target comes next is
// the for_each's `order:`, run by the executor, so choosing cannot be split between the two.
#include "projtour/contract/plugin_author.hpp"

namespace projtour {
namespace {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
}  // namespace outcome

class Next : public Behaviour {
 public:
  Next(const Params&, const RunContext&) {}

  void start(Context& ctx) override {
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
    if (ctx.drivers().pan_tilt) {
      const PanTiltSpec& pt = ctx.robot().pan_tilt;
      ctx.drivers().pan_tilt->command({deg_to_rad(pt.stow_pan_deg), deg_to_rad(pt.stow_tilt_deg)});
    }
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (ctx.cancel_requested()) return Outcome{kOutcomeCancelled, "cancelled while stowing"};
    if (ctx.drivers().pan_tilt && !ctx.drivers().pan_tilt->reached()) return std::nullopt;
    return Outcome{outcome::kSucceeded, "projector blank, head stowed"};
  }

  void stop(Context& ctx) override {
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
  }
};

const char* const kOutcomes[] = {outcome::kSucceeded};
const projtour_kind_desc kKinds[] = {
    behaviour_kind<Next>("next", "blank the projector and stow the head", kOutcomes)};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("next", "2.0.0", projtour::kKinds)
