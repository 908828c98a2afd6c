#include "navigate.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/navigation/localizer.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace projtour::navigate {

namespace {

// Turn in place rather than drive when the carrot is this far off the heading.
constexpr double kTurnInPlaceRad = 0.9;
// Held up by something ahead, it turns towards the path unless already this well on it.
constexpr double kAlignedRad = 0.1;
// Slow down over the last stretch so the stop lands within tolerance.
constexpr double kApproachGain = 0.8;  // (m/s) per m
constexpr double kMinApproachSpeedMps = 0.04;
constexpr double kTurnGain = 1.5;  // (rad/s) per rad
constexpr double kMinTurnRateRadps = 0.05;
// Aim for a fraction of the tolerance so the estimate's jitter does not push it out again.
constexpr double kAimFraction = 0.4;
// Counts as progress.
constexpr double kProgressM = 0.05;
constexpr double kReplanPeriodS = 1.0;
// A path blocks on what is already within the clearance only if it leads this much nearer.
constexpr double kNearerM = 0.02;
// Re-approach stand-offs are tried this far apart.
constexpr double kReapproachStepM = 0.05;
// What the laser sees that the map lacks (furniture, people) is kept this much farther off
// than the map's walls: the robot's radius plus this, with the planner's own margin on top.
constexpr double kUnmappedClearanceM = 0.15;
// The speed it may drive at is what it could stop from before coming within its radius plus
// kStopClearanceM of anything the laser sees ahead that the map lacks: pure pursuit cuts the
// path's corners, and people step in beside it.
constexpr double kStopClearanceM = 0.12;
constexpr double kStopTimeS = 0.6;

double clamp(double v, double limit) {
  return std::max(-limit, std::min(limit, v));
}

}  // namespace

Navigate::Navigate(const Params& params, const RunContext& run)
    : tolerance_m_(params.number(param::kToleranceM)),
      tolerance_rad_(deg_to_rad(params.number(param::kToleranceDeg))),
      lookahead_m_(params.number(param::kLookaheadM)),
      max_speed_mps_(params.number(param::kMaxSpeedMps)),
      max_turn_rate_radps_(deg_to_rad(params.number(param::kMaxTurnRateDps))),
      blocked_s_(params.number(param::kBlockedS)),
      timeout_s_(params.number(param::kTimeoutS)),
      lost_std_m_(params.number(param::kLostStdM)),
      lost_unconverged_s_(params.number(param::kLostUnconvergedS)),
      obstacle_lookahead_m_(params.number(param::kObstacleLookaheadM)),
      max_detour_m_(params.number(param::kMaxDetourM)),
      reapproach_margin_px_(params.number(param::kReapproachMarginPx)),
      reapproach_max_extra_m_(params.number(param::kReapproachMaxExtraM)) {
  if (!run.map) throw std::runtime_error("navigate needs the mission's map");
  const double radius_m = run.mission != nullptr ? run.mission->robot.base.radius_m : 0.35;
  if (run.mission != nullptr) {
    // Zero means "as fast as the robot file allows".
    if (max_speed_mps_ <= 0.0) max_speed_mps_ = run.mission->robot.base.max_speed_mps;
    if (max_turn_rate_radps_ <= 0.0) {
      max_turn_rate_radps_ = deg_to_rad(run.mission->robot.base.max_turn_rate_dps);
    }
  }
  if (max_speed_mps_ <= 0.0) max_speed_mps_ = 0.5;
  if (max_turn_rate_radps_ <= 0.0) max_turn_rate_radps_ = deg_to_rad(60.0);
  map_planner_ = std::make_shared<const navigation::PathPlanner>(*run.map, radius_m);
}

void Navigate::command(Context& ctx, double v_mps, double w_radps) {
  ctx.drivers().base->command_velocity(v_mps, w_radps);
}

void Navigate::start(Context& ctx) {
  if (ctx.target == nullptr) throw std::runtime_error("navigate runs for a target");
  if (!ctx.drivers().base) throw std::runtime_error("navigate needs a base driver");
  // The projector stays dark while the base moves.
  if (ctx.drivers().projector) ctx.drivers().projector->blank();
  early_.reset();
  // Back at a target align has measured (aim's reapproach), the stand-off is taken from where the
  // target really stands, not from where the map has it, and as much farther than the target's
  // standoff_m as the content needs to fit the projector image.
  if (const auto T_map_model =
          head::aligned_T_map_model(ctx.robot(), ctx.blackboard().find(keys::kAlign),
                                    ctx.blackboard().find(keys::kCapture))) {
    TargetSpec measured = *ctx.target;
    measured.T_map_model = *T_map_model;
    const head::HeadKinematics kinematics =
        head::believed_kinematics(ctx.robot(), ctx.blackboard().find(keys::kCalibration));
    Eigen::Vector3d p_aim = Eigen::Vector3d::Zero();
    for (const auto& p : measured.model_points) p_aim += p / 4.0;
    std::optional<double> chosen_m;
    std::string problem = "no stand-off searched";
    const int steps =
        static_cast<int>(std::floor(reapproach_max_extra_m_ / kReapproachStepM + 1e-9));
    for (int k = 0; k <= steps && !chosen_m; ++k) {
      measured.standoff_m = ctx.target->standoff_m + k * kReapproachStepM;
      const Pose2D candidate = navigation::standoff_pose(measured);
      if (!map_planner_->grid().fits(Eigen::Vector2d(candidate.x_m, candidate.y_m))) {
        problem = "the stand-off " + std::to_string(measured.standoff_m) + " m off is not free";
        continue;
      }
      problem = head::content_fit_problem(
          kinematics, ctx.robot().projector.intrinsics, measured.model_points, p_aim,
          isometry_from_pose2d(candidate).inverse() * *T_map_model, reapproach_margin_px_);
      if (problem.empty()) {
        goal_ = candidate;
        chosen_m = measured.standoff_m;
      }
    }
    if (!chosen_m) {
      // Driving to where the content cannot fit either would only bring aim back here.
      early_ = Outcome{outcome::kUnreachable,
                       "target " + ctx.target->id + ": from no free stand-off up to " +
                           std::to_string(measured.standoff_m) +
                           " m off its aligned pose does the content fit the "
                           "projector image (" +
                           problem + ")"};
      return;
    }
    ctx.log().debug("navigate " + ctx.target->id + ": re-approaching the aligned pose from " +
                    std::to_string(*chosen_m) + " m");
  } else {
    goal_ = navigation::standoff_pose(*ctx.target);
  }
  planner_ = std::make_unique<navigation::PathPlanner>(*map_planner_);
  path_ = navigation::PlannedPath{};
  result_ = NavigateResult{};
  progress_index_ = 0;
  final_turn_ = false;
  // State time, not mission time: a pause (operator, SIGUSR1) longer than blocked_s must not
  // read as no progress, nor count towards the timeout, on the first tick after the resume.
  start_s_ = ctx.state_elapsed_s();
  last_progress_s_ = start_s_;
  last_replan_s_ = -1e9;
  last_converged_s_ = start_s_;
  best_remaining_m_ = std::numeric_limits<double>::infinity();
  rebase_progress_ = false;
}

bool Navigate::replan(Context& ctx, const Pose2D& from, double max_length_m) {
  last_replan_s_ = ctx.state_elapsed_s();
  auto path = planner_->plan({from.x_m, from.y_m}, {goal_.x_m, goal_.y_m});
  if (!path) return false;
  double length_m = 0.0;
  for (std::size_t i = 1; i < path->points_m.size(); ++i) {
    length_m += (path->points_m[i] - path->points_m[i - 1]).norm();
  }
  if (length_m > max_length_m) return false;
  path_ = std::move(*path);
  progress_index_ = 0;
  // A detour around what the laser sees is longer than the path it replaces: progress is then
  // measured along the new path from where it starts, or driving round a person would read as
  // none (issue 14: seed 3's rabbit was left "blocked" while the robot drove its detour).
  rebase_progress_ = true;
  std::vector<Pose2D> poses;
  for (std::size_t i = 0; i < path_.points_m.size(); ++i) {
    const Eigen::Vector2d& p = path_.points_m[i];
    Eigen::Vector2d d = Eigen::Vector2d::UnitX();
    if (i + 1 < path_.points_m.size()) {
      d = path_.points_m[i + 1] - p;
    } else if (i > 0) {
      d = p - path_.points_m[i - 1];
    }
    poses.push_back(Pose2D{p.x(), p.y(), std::atan2(d.y(), d.x())});
  }
  if (!poses.empty()) poses.back().yaw_rad = goal_.yaw_rad;
  result_.planned_path = std::move(poses);
  ctx.blackboard().set(keys::kNavigate, result_);
  return true;
}

double Navigate::remaining_m(const Pose2D& pose) {
  const Eigen::Vector2d p(pose.x_m, pose.y_m);
  // Advance along the path while the next point is closer: the path never goes backwards.
  const std::size_t window_end = std::min(path_.points_m.size(), progress_index_ + 15);
  std::size_t best = progress_index_;
  for (std::size_t i = progress_index_; i < window_end; ++i) {
    if ((path_.points_m[i] - p).norm() < (path_.points_m[best] - p).norm()) best = i;
  }
  progress_index_ = best;
  double left_m = (path_.points_m[best] - p).norm();
  for (std::size_t i = best + 1; i < path_.points_m.size(); ++i) {
    left_m += (path_.points_m[i] - path_.points_m[i - 1]).norm();
  }
  return left_m;
}

std::vector<Eigen::Vector2d> Navigate::obstacles_on_path(Context& ctx, const Pose2D& pose) const {
  std::vector<Eigen::Vector2d> hits;
  const LaserScan* scan = ctx.blackboard().find(keys::kLaserScan);
  if (!scan || path_.points_m.empty()) return hits;
  const Eigen::Isometry3d T_map_laser = isometry_from_pose2d(pose) * scan->T_base_laser;
  const navigation::InflatedGrid& grid = map_planner_->grid();
  const double clearance_m = grid.robot_radius_m() + kUnmappedClearanceM;
  const Eigen::Vector2d robot(pose.x_m, pose.y_m);
  for (std::size_t i = 0; i < scan->ranges_m.size(); ++i) {
    if (i < scan->valid.size() && !scan->valid[i]) continue;
    const double r = scan->ranges_m[i];
    if (!(r > 0.0) || r >= scan->max_range_m || r > obstacle_lookahead_m_ + clearance_m) continue;
    const double a = scan->angle_min_rad + i * scan->angle_increment_rad;
    const Eigen::Vector3d p_map =
        T_map_laser * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0);
    const Eigen::Vector2d p = p_map.head<2>();
    // What the map already has is planned around; only new things block.
    if (!grid.is_free_space(p)) continue;
    // Something already nearer than the clearance (a person who stepped up beside it) blocks
    // only a path that comes nearer still: every path starts where the robot stands, and one that
    // leads away must be allowed, or the robot waits beside it forever.
    const double blocking_m = std::min(clearance_m, (p - robot).norm() - kNearerM);
    double along_m = 0.0;
    for (std::size_t k = progress_index_; k + 1 < path_.points_m.size(); ++k) {
      const Eigen::Vector2d a_m = path_.points_m[k], b_m = path_.points_m[k + 1];
      const Eigen::Vector2d ab = b_m - a_m;
      const double t =
          ab.squaredNorm() > 0 ? std::clamp((p - a_m).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      if ((a_m + t * ab - p).norm() < blocking_m) {
        hits.push_back(p);
        break;
      }
      along_m += ab.norm();
      if (along_m > obstacle_lookahead_m_) break;
    }
  }
  return hits;
}

// Lost (the estimate too wide, or its scans off the map too long) or out of time.
std::optional<Outcome> Navigate::check_localization(Context& ctx, const PoseEstimate2D& estimate,
                                                    double now_s) {
  if (navigation::position_std_m(estimate) > lost_std_m_) {
    command(ctx, 0, 0);
    return Outcome{outcome::kLost, "localization standard deviation " +
                                       std::to_string(navigation::position_std_m(estimate)) +
                                       " m exceeds " + std::to_string(lost_std_m_) + " m"};
  }
  // A tight cloud whose scans no longer fit the map is as lost as a wide one.
  const bool* converged = ctx.blackboard().find(keys::kLocalizationConverged);
  if (converged == nullptr || *converged) {
    last_converged_s_ = now_s;
  } else if (now_s - last_converged_s_ > lost_unconverged_s_) {
    command(ctx, 0, 0);
    return Outcome{outcome::kLost,
                   "localization not converged for " + std::to_string(lost_unconverged_s_) + " s"};
  }
  if (now_s - start_s_ > timeout_s_) {
    command(ctx, 0, 0);
    return Outcome{outcome::kTimeout,
                   "goal not reached within " + std::to_string(timeout_s_) + " s"};
  }
  return std::nullopt;
}

// What the laser sees on the path goes onto the planner's grid, and a way round it is taken
// when there is one not much longer than the path left.
void Navigate::detour(Context& ctx, const Pose2D& pose,
                      const std::vector<Eigen::Vector2d>& obstacles) {
  // Each point grown into a disc of kUnmappedClearanceM: the new path keeps the robot's
  // radius plus that from it.
  std::vector<Eigen::Vector2d> grown;
  const double step_m = 0.5 * planner_->grid().resolution_m();
  for (const Eigen::Vector2d& p : obstacles) {
    for (double dy = -kUnmappedClearanceM; dy <= kUnmappedClearanceM + 1e-9; dy += step_m) {
      for (double dx = -kUnmappedClearanceM; dx <= kUnmappedClearanceM + 1e-9; dx += step_m) {
        if (std::hypot(dx, dy) <= kUnmappedClearanceM) grown.push_back(p + Eigen::Vector2d(dx, dy));
      }
    }
  }
  planner_->grid().add_obstacles(grown);
  if (!replan(ctx, pose, remaining_m(pose) + max_detour_m_)) {
    // No way round, or only a long one: wait on the path it has, for what blocks it may
    // move away; forget what was seen and try again next period.
    planner_ = std::make_unique<navigation::PathPlanner>(*map_planner_);
  }
}

// The drive along the path, slowed near the goal and for what stands ahead.
void Navigate::pursue(Context& ctx, const Pose2D& pose, double goal_dist_m) {
  // Pure pursuit: steer for the point lookahead_m along the path (the goal itself at the end).
  const Eigen::Vector2d position(pose.x_m, pose.y_m);
  Eigen::Vector2d carrot = path_.points_m.back();
  for (std::size_t i = progress_index_; i < path_.points_m.size(); ++i) {
    if ((path_.points_m[i] - position).norm() >= lookahead_m_) {
      carrot = path_.points_m[i];
      break;
    }
  }
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  const Eigen::Vector2d d = carrot - position;
  const double local_x = c * d.x() + s * d.y(), local_y = -s * d.x() + c * d.y();
  const double alpha = std::atan2(local_y, local_x);
  const double distance_m = std::max(1e-3, d.norm());
  if (std::abs(alpha) > kTurnInPlaceRad) {
    command(ctx, 0, clamp(kTurnGain * alpha, max_turn_rate_radps_));
    return;
  }
  double v = std::min(max_speed_mps_, std::max(kMinApproachSpeedMps, kApproachGain * goal_dist_m));
  const double safe_mps = safe_speed_mps(ctx, pose);
  if (safe_mps < kMinApproachSpeedMps && std::abs(alpha) > kAlignedRad) {
    // Too near something ahead to drive, but the path turns off: a round base turns in place
    // without coming nearer anything, and what is then abeam no longer holds it.
    const double w_turn = clamp(kTurnGain * alpha, max_turn_rate_radps_);
    command(ctx, 0, std::copysign(std::max(std::abs(w_turn), kMinTurnRateRadps), w_turn));
    return;
  }
  v = std::min(v, safe_mps);
  v *= std::cos(alpha);
  double w = 2.0 * v * std::sin(alpha) / distance_m;
  if (std::abs(w) > max_turn_rate_radps_) {
    v *= max_turn_rate_radps_ / std::abs(w);
    w = clamp(w, max_turn_rate_radps_);
  }
  command(ctx, v, w);
}

std::optional<Outcome> Navigate::tick(Context& ctx) {
  if (early_) return early_;
  if (ctx.cancel_requested()) {
    command(ctx, 0, 0);
    return Outcome{kOutcomeCancelled, "cancelled"};
  }
  const double now_s = ctx.state_elapsed_s();
  const PoseEstimate2D* estimate = ctx.blackboard().find(keys::kLocalization);
  if (estimate == nullptr) {
    command(ctx, 0, 0);
    return Outcome{kOutcomeFailed, "no localization estimate on the blackboard"};
  }
  const Pose2D pose = estimate->mean;
  if (auto ended = check_localization(ctx, *estimate, now_s)) return ended;

  if (path_.points_m.empty()) {
    if (!replan(ctx, pose)) {
      command(ctx, 0, 0);
      return Outcome{outcome::kUnreachable, "no path to the stand-off pose (" +
                                                std::to_string(goal_.x_m) + ", " +
                                                std::to_string(goal_.y_m) + ")"};
    }
  }

  const Eigen::Vector2d to_goal(goal_.x_m - pose.x_m, goal_.y_m - pose.y_m);
  const double goal_dist_m = to_goal.norm();
  const double yaw_error_rad = wrap_angle_rad(goal_.yaw_rad - pose.yaw_rad);
  // Done once the final turn has brought the heading well inside the tolerance, so the stop is
  // not on the edge of it.
  if (final_turn_ && goal_dist_m <= tolerance_m_ &&
      std::abs(yaw_error_rad) <= kAimFraction * tolerance_rad_) {
    command(ctx, 0, 0);
    result_.arrived_at = *estimate;
    ctx.blackboard().set(keys::kNavigate, result_);
    return Outcome{outcome::kSucceeded, ""};
  }

  // Progress: path left plus the heading still to turn once there.
  const double remaining =
      remaining_m(pose) + (final_turn_ ? 0.3 * std::abs(yaw_error_rad) : 0.3 * kPi);
  if (rebase_progress_) {
    rebase_progress_ = false;
    best_remaining_m_ = remaining;
  } else if (remaining < best_remaining_m_ - kProgressM) {
    best_remaining_m_ = remaining;
    last_progress_s_ = now_s;
  } else if (now_s - last_progress_s_ > blocked_s_) {
    command(ctx, 0, 0);
    return Outcome{outcome::kBlocked, "no progress for " + std::to_string(blocked_s_) + " s"};
  }

  if (!final_turn_) {
    const auto obstacles = obstacles_on_path(ctx, pose);
    if (!obstacles.empty()) {
      command(ctx, 0, 0);
      if (now_s - last_replan_s_ >= kReplanPeriodS) detour(ctx, pose, obstacles);
      return std::nullopt;
    }
  }

  if (goal_dist_m <= kAimFraction * tolerance_m_) final_turn_ = true;
  if (final_turn_ && goal_dist_m > tolerance_m_) final_turn_ = false;
  if (final_turn_) {
    const double w = clamp(kTurnGain * yaw_error_rad, max_turn_rate_radps_);
    command(ctx, 0, std::copysign(std::max(std::abs(w), kMinTurnRateRadps), w));
    return std::nullopt;
  }

  pursue(ctx, pose, goal_dist_m);
  return std::nullopt;
}

double Navigate::safe_speed_mps(Context& ctx, const Pose2D& pose) const {
  const LaserScan* scan = ctx.blackboard().find(keys::kLaserScan);
  if (!scan) return max_speed_mps_;
  const Eigen::Isometry3d T_map_laser = isometry_from_pose2d(pose) * scan->T_base_laser;
  const navigation::InflatedGrid& grid = map_planner_->grid();
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  double speed_mps = max_speed_mps_;
  const double keep_m = grid.robot_radius_m() + kStopClearanceM;
  for (std::size_t i = 0; i < scan->ranges_m.size(); ++i) {
    if (i < scan->valid.size() && !scan->valid[i]) continue;
    const double r = scan->ranges_m[i];
    if (!(r > 0.0) || r >= scan->max_range_m || r > 3.0) continue;
    const double a = scan->angle_min_rad + i * scan->angle_increment_rad;
    const Eigen::Vector2d p =
        (T_map_laser * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0)).head<2>();
    if (!grid.is_free_space(p)) continue;  // the map's walls are planned around
    const Eigen::Vector2d d = p - Eigen::Vector2d(pose.x_m, pose.y_m);
    // Driving forward brings it nearer at v cos(bearing): what lies abeam does not limit the
    // speed, what lies ahead does.
    const double distance_m = d.norm();
    const double closing = (c * d.x() + s * d.y()) / std::max(distance_m, 1e-9);
    if (closing <= 0.05) continue;
    // What is already nearer than keep_m (someone who stepped up beside it) holds the robot only
    // if driving on brings it nearer still, as a path does: else it stands there forever.
    const double abeam_m = distance_m * std::sqrt(std::max(0.0, 1.0 - closing * closing));
    if (distance_m < keep_m && abeam_m >= distance_m - kNearerM) continue;
    speed_mps = std::min(speed_mps, std::max(0.0, distance_m - keep_m) / (kStopTimeS * closing));
  }
  return speed_mps;
}

void Navigate::stop(Context& ctx) {
  if (ctx.drivers().base) command(ctx, 0, 0);
}

void Navigate::pause(Context& ctx) {
  if (ctx.drivers().base) command(ctx, 0, 0);
}

}  // namespace projtour::navigate
