// aim: turn the head so the projector's optical axis passes through the target's projection
// area. The aim point is the centroid of the four Model Points in the map (the centre of the
// content), or the model origin with `aim_at: origin`. The projector stays blank while the head
// moves; the step succeeds once the driver reports the angles reached and `settle_s` has passed.
// Aiming again after align (re-aim: the aligned pose put a Model Point off the projector image)
// aims at the aligned pose rather than the map's, and through the calibration believed now; when
// even then the content would not fit the projector image (the target stands nearer than the map
// has it), the outcome is reapproach: navigate takes the base to the stand-off from the aligned
// pose.
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/head/kinematics.hpp"

namespace projtour {
namespace {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kOutOfReach = "out_of_reach";
inline constexpr const char* kReapproach = "reapproach";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kSettleS = "settle_s";
inline constexpr const char* kAimAt = "aim_at";
inline constexpr const char* kEdgeMarginPx = "edge_margin_px";
}  // namespace param

std::string fmt_angles(const JointAngles& q) {
  std::ostringstream s;
  s.precision(2);
  s << std::fixed << "pan " << rad_to_deg(q.pan_rad) << " deg, tilt " << rad_to_deg(q.tilt_rad)
    << " deg";
  return s.str();
}

class Aim : public Behaviour {
 public:
  Aim(const Params& params, const RunContext& run)
      : settle_s_(params.number(param::kSettleS)),
        edge_margin_px_(params.number(param::kEdgeMarginPx)),
        aim_at_origin_(params.string(param::kAimAt) == "origin") {
    if (run.mission == nullptr) throw std::invalid_argument("aim needs the mission's robot");
  }

  void start(Context& ctx) override {
    early_.reset();
    reached_at_s_.reset();
    holding_ = false;
    if (ctx.target == nullptr) throw std::runtime_error("aim runs only inside a visit to a target");
    const TargetSpec& target = *ctx.target;
    const PoseEstimate2D* estimate = ctx.blackboard().find(keys::kLocalization);
    if (!estimate) {
      early_ = Outcome{kOutcomeFailed, "target " + target.id +
                                           ": no localization estimate on the blackboard (" +
                                           keys::kLocalization.name + "); cannot aim"};
      return;
    }
    if (!ctx.drivers().pan_tilt) {
      early_ = Outcome{kOutcomeFailed, "target " + target.id + ": no pan-tilt driver"};
      return;
    }
    Eigen::Vector3d p_model = Eigen::Vector3d::Zero();
    if (!aim_at_origin_) {
      for (const auto& p : target.model_points) p_model += p / 4.0;
    }
    const head::HeadKinematics kinematics =
        head::believed_kinematics(ctx.robot(), ctx.blackboard().find(keys::kCalibration));
    const auto T_base_aligned =
        head::aligned_T_base_model(ctx.robot(), ctx.blackboard().find(keys::kAlign),
                                   ctx.blackboard().find(keys::kCapture), estimate->mean);
    if (T_base_aligned) ctx.log().debug("aim " + target.id + ": re-aiming at the aligned pose");
    const Eigen::Isometry3d T_base_model =
        T_base_aligned ? *T_base_aligned
                       : isometry_from_pose2d(estimate->mean).inverse() * target.T_map_model;
    const Eigen::Vector3d p_base = T_base_model * p_model;
    std::string why;
    const auto q = kinematics.aim_projector_at(p_base, &why);
    if (!q) {
      std::ostringstream s;
      s.precision(2);
      s << std::fixed << "target " << target.id << ": aim point (" << p_base.x() << ", "
        << p_base.y() << ", " << p_base.z() << ") m in the base frame is out of reach: " << why;
      // Aimed at where the target really is, a farther stand-off may bring it within reach.
      early_ = Outcome{T_base_aligned ? outcome::kReapproach : outcome::kOutOfReach, s.str()};
      return;
    }
    if (T_base_aligned) {
      // Where the target really is, its content may not fit the projector image from this
      // stand-off at any angle (a target nearer than the map has it): the base re-approaches.
      const std::string problem =
          head::content_fit_problem(kinematics, ctx.robot().projector.intrinsics,
                                    target.model_points, p_model, T_base_model, edge_margin_px_);
      if (!problem.empty()) {
        early_ =
            Outcome{outcome::kReapproach, "target " + target.id + ": aimed at its aligned pose, " +
                                              problem + "; the base re-approaches it"};
        return;
      }
    }
    goal_ = *q;
    // Never light the scene while the head sweeps.
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
    ctx.drivers().pan_tilt->command(goal_);
    ctx.log().debug("aim " + target.id + ": " + fmt_angles(goal_));
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (early_) return early_;
    if (ctx.cancel_requested()) {
      hold(ctx);
      return Outcome{kOutcomeCancelled, "cancelled while aiming"};
    }
    if (!ctx.drivers().pan_tilt->reached()) {
      reached_at_s_.reset();
      return std::nullopt;
    }
    if (!reached_at_s_) reached_at_s_ = ctx.state_elapsed_s();
    if (ctx.state_elapsed_s() - *reached_at_s_ < settle_s_) return std::nullopt;
    return Outcome{outcome::kSucceeded, "aimed at " + ctx.target->id + ": " + fmt_angles(goal_)};
  }

  // Leaves the projector blank and the head still: a head stopped on its way (a timeout, a
  // failure) holds where it is; one already held (paused, cancelled) or at its goal gets no
  // new command, so a stop after a pause moves nothing.
  void stop(Context& ctx) override {
    if (early_) return;
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
    if (!holding_ && ctx.drivers().pan_tilt && !ctx.drivers().pan_tilt->reached()) hold(ctx);
  }

  void pause(Context& ctx) override { hold(ctx); }
  void resume(Context& ctx) override {
    reached_at_s_.reset();
    holding_ = false;
    if (!early_ && ctx.drivers().pan_tilt) ctx.drivers().pan_tilt->command(goal_);
  }

 private:
  // Stops the head where it is.
  void hold(Context& ctx) {
    if (ctx.drivers().pan_tilt) {
      ctx.drivers().pan_tilt->command(ctx.drivers().pan_tilt->measured());
      holding_ = true;
    }
  }

  double settle_s_;
  double edge_margin_px_;
  bool aim_at_origin_;
  JointAngles goal_;
  std::optional<Outcome> early_;
  std::optional<double> reached_at_s_;  // state time the head was first seen at its goal
  bool holding_ = false;                // hold() was the last head command
};

void check_params(const Params& params) {
  const std::string& aim_at = params.string(param::kAimAt);
  if (aim_at != "model_points" && aim_at != "origin") {
    throw std::invalid_argument("aim_at must be \"model_points\" or \"origin\", not \"" + aim_at +
                                "\"");
  }
  if (params.number(param::kSettleS) < 0) throw std::invalid_argument("settle_s must be >= 0");
  if (params.number(param::kEdgeMarginPx) < 0) {
    throw std::invalid_argument("edge_margin_px must be >= 0");
  }
}

const projtour_param_desc kParams[] = {
    {param::kSettleS, "number", "0.3", "seconds to wait after the head reports its angles reached"},
    {param::kAimAt, "string", "model_points",
     "model_points (centroid of the four Model Points) or origin (the model frame's origin)"},
    {param::kEdgeMarginPx, "number", "10",
     "aiming at the aligned pose: a Model Point closer than this to the projector image's edge "
     "means reapproach (more than calibrate's and verify's margin, so what fits here fits "
     "there)"}};
const char* const kOutcomes[] = {outcome::kSucceeded, outcome::kOutOfReach, outcome::kReapproach};
const projtour_key_desc kKeys[] = {reads(keys::kLocalization), reads_if_present(keys::kAlign),
                                   reads_if_present(keys::kCapture),
                                   reads_if_present(keys::kCalibration)};
const projtour_kind_desc kKinds[] = {
    with_keys(behaviour_kind<Aim>("aim",
                                  "pan-tilt inverse kinematics: projector optical axis onto the "
                                  "target",
                                  kParams, kOutcomes, validator<check_params>()),
              kKeys)};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("aim", "1.0.0", projtour::kKinds)
