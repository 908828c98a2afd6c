#pragma once
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "projtour/behaviour.hpp"
#include "projtour/blackboard_keys.hpp"
#include "projtour/path_planner.hpp"

namespace projtour::navigate {

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

  // Parameters.
  double tolerance_m_, tolerance_rad_, lookahead_m_, max_speed_mps_, max_turn_rate_radps_;
  double blocked_s_, timeout_s_, lost_std_m_, lost_unconverged_s_, obstacle_lookahead_m_,
      max_detour_m_;
  double reapproach_margin_px_, reapproach_max_extra_m_;
  std::optional<Outcome> early_;  // decided in start(): no stand-off to re-approach from

  std::shared_ptr<const PathPlanner> map_planner_;  // the map as loaded
  std::unique_ptr<PathPlanner> planner_;            // plus what the laser saw on this run
  Pose2D goal_;
  PlannedPath path_;
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
