#pragma once
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/navigation/path_planner.hpp"

namespace projtour::navigate {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kUnreachable = "unreachable";
inline constexpr const char* kBlocked = "blocked";
inline constexpr const char* kTimeout = "timeout";
inline constexpr const char* kLost = "lost";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kToleranceM = "tolerance_m";
inline constexpr const char* kToleranceDeg = "tolerance_deg";
inline constexpr const char* kLookaheadM = "lookahead_m";
inline constexpr const char* kMaxSpeedMps = "max_speed_mps";
inline constexpr const char* kMaxTurnRateDps = "max_turn_rate_dps";
inline constexpr const char* kBlockedS = "blocked_s";
inline constexpr const char* kTimeoutS = "timeout_s";
inline constexpr const char* kLostStdM = "lost_std_m";
inline constexpr const char* kLostUnconvergedS = "lost_unconverged_s";
inline constexpr const char* kObstacleLookaheadM = "obstacle_lookahead_m";
inline constexpr const char* kMaxDetourM = "max_detour_m";
inline constexpr const char* kReapproachMarginPx = "reapproach_margin_px";
inline constexpr const char* kReapproachMaxExtraM = "reapproach_max_extra_m";
inline constexpr const char* kWidenM = "widen_m";
inline constexpr const char* kSpinRateDps = "spin_rate_dps";
inline constexpr const char* kGiveUpS = "give_up_s";
inline constexpr const char* kSettleS = "settle_s";
inline constexpr const char* kConvergedStdM = "converged_std_m";
}  // namespace param

// Drives to the current target's stand-off pose (from its aligned pose when align has measured
// it in this visit). Outcomes: succeeded (the localized estimate
// within the goal tolerance), unreachable (no path), blocked (no progress for blocked_s),
// timeout, lost (the estimate's standard deviation over lost_std_m).
class Navigate : public Behaviour {
 public:
  Navigate(const Params& params, const RunContext& run);
  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;
  void stop(Context& ctx) override;
  void pause(Context& ctx) override;

 private:
  // Takes a new path unless none exists or it is longer than max_length_m.
  bool replan(Context& ctx, const Pose2D& from,
              double max_length_m = std::numeric_limits<double>::infinity());
  // Laser points not on the map that lie on the path ahead, in the map frame.
  std::vector<Eigen::Vector2d> obstacles_on_path(Context& ctx, const Pose2D& pose) const;
  // How fast it may drive and still stop short of what the laser sees ahead.
  double safe_speed_mps(Context& ctx, const Pose2D& pose) const;
  // Path length left from the closest point ahead of `progress_index_`.
  double remaining_m(const Pose2D& pose);
  void command(Context& ctx, double v_mps, double w_radps);
  // tick's stages: the estimate's health and the time left, the way round what blocks the path,
  // and the drive along it.
  std::optional<Outcome> check_localization(Context& ctx, const PoseEstimate2D& estimate,
                                            double now_s);
  void detour(Context& ctx, const Pose2D& pose, const std::vector<Eigen::Vector2d>& obstacles);
  void pursue(Context& ctx, const Pose2D& pose, double goal_dist_m);

  // Parameters.
  double tolerance_m_, tolerance_rad_, lookahead_m_, max_speed_mps_, max_turn_rate_radps_;
  double blocked_s_, timeout_s_, lost_std_m_, lost_unconverged_s_, obstacle_lookahead_m_,
      max_detour_m_;
  double reapproach_margin_px_, reapproach_max_extra_m_;
  std::optional<Outcome> early_;  // decided in start(): no stand-off to re-approach from

  std::shared_ptr<const navigation::PathPlanner> map_planner_;  // the map as loaded
  std::unique_ptr<navigation::PathPlanner> planner_;  // plus what the laser saw on this run
  Pose2D goal_;
  navigation::PlannedPath path_;
  NavigateResult result_;
  std::size_t progress_index_ = 0;
  double start_s_ = 0.0;
  double best_remaining_m_ = 0.0;
  double last_progress_s_ = 0.0;
  bool rebase_progress_ = false;  // set by a new plan
  double last_replan_s_ = -1e9;
  double last_converged_s_ = 0.0;
  bool final_turn_ = false;
};

// Spins in place and widens the localization's particle cloud until it converges (succeeded)
// or gives up (lost).
class Relocalize : public Behaviour {
 public:
  Relocalize(const Params& params, const RunContext& run);
  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;
  void stop(Context& ctx) override;

 private:
  double widen_m_, spin_rate_radps_, give_up_s_, settle_s_, converged_std_m_;
  double start_s_ = 0.0;
  double converged_since_s_ = -1.0;
};

}  // namespace projtour::navigate
