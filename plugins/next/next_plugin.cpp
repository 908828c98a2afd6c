// next: leave the target safely (projector blank, head stowed) and choose where to go next.
// Done targets are those in keys::kDoneTargets plus the one being left. `order: mission` takes
// the first remaining target in mission order; `order: nearest` the one with the shortest path
// on the map (grid inflated by the robot's radius) from the localized pose to its stand-off pose;
// targets without a path go last, in mission order, so navigate reports them unreachable.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "projtour/blackboard_keys.hpp"
#include "projtour/occupancy_map.hpp"
#include "projtour/path_planner.hpp"
#include "projtour/plugin_author.hpp"

namespace projtour {
namespace {

class Next : public Behaviour {
 public:
  Next(const Params& params, const RunContext& run) : order_(params.string("order")) {
    if (run.mission == nullptr) throw std::invalid_argument("next needs the mission");
    if (order_.empty()) order_ = run.mission->order;
  }

  void start(Context& ctx) override {
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
    if (ctx.target != nullptr) mark_done(ctx, ctx.target->id);
    if (ctx.drivers().pan_tilt) {
      const PanTiltSpec& pt = ctx.robot().pan_tilt;
      ctx.drivers().pan_tilt->command({deg_to_rad(pt.stow_pan_deg), deg_to_rad(pt.stow_tilt_deg)});
    }
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (ctx.cancel_requested()) return Outcome{kOutcomeCancelled, "cancelled while stowing"};
    if (ctx.drivers().pan_tilt && !ctx.drivers().pan_tilt->reached()) return std::nullopt;
    return choose(ctx);
  }

  void stop(Context& ctx) override {
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
  }

 private:
  static void mark_done(Context& ctx, const std::string& id) {
    auto done = ctx.blackboard()
                    .get<std::vector<std::string>>(keys::kDoneTargets)
                    .value_or(std::vector<std::string>{});
    if (std::find(done.begin(), done.end(), id) == done.end()) done.push_back(id);
    ctx.blackboard().set(keys::kDoneTargets, std::move(done));
  }

  Outcome choose(Context& ctx) {
    const MissionSpec& mission = ctx.mission();
    const auto done = ctx.blackboard()
                          .get<std::vector<std::string>>(keys::kDoneTargets)
                          .value_or(std::vector<std::string>{});
    std::vector<std::size_t> remaining;
    for (std::size_t i = 0; i < mission.targets.size(); ++i) {
      if (std::find(done.begin(), done.end(), mission.targets[i].id) == done.end()) {
        remaining.push_back(i);
      }
    }
    if (remaining.empty()) return Outcome{"finished", "every target visited"};

    std::size_t chosen = remaining.front();
    std::string how = "mission order";
    if (order_ == "nearest") {
      const auto estimate = ctx.blackboard().get<PoseEstimate2D>(keys::kLocalization);
      if (!estimate) {
        return Outcome{kOutcomeFailed,
                       std::string("order nearest needs a localization estimate (") +
                           keys::kLocalization + ")"};
      }
      const Eigen::Vector2d here(estimate->mean.x_m, estimate->mean.y_m);
      double best_m = std::numeric_limits<double>::infinity();
      for (std::size_t i : remaining) {
        const double length_m = path_length_m(ctx, here, mission.targets[i]);
        if (length_m < best_m) {  // strict: ties keep mission order
          best_m = length_m;
          chosen = i;
        }
      }
      std::ostringstream s;
      s.precision(2);
      s << std::fixed << "nearest, path " << best_m << " m";
      how = std::isfinite(best_m) ? s.str() : "no target has a path; mission order";
    }
    ctx.blackboard().set<long long>(keys::kNextTargetIndex, static_cast<long long>(chosen));
    return Outcome{"succeeded", "next target " + mission.targets[chosen].id + " (" + how + ")"};
  }

  // Path length to the target's stand-off pose; straight line when the run has no map.
  double path_length_m(Context& ctx, const Eigen::Vector2d& from, const TargetSpec& target) {
    const Pose2D goal = standoff_pose(target);
    const Eigen::Vector2d to(goal.x_m, goal.y_m);
    if (!ctx.run->map) {
      if (!warned_no_map_) ctx.log().warning("next: no map, ranking targets by straight line");
      warned_no_map_ = true;
      return (to - from).norm();
    }
    if (!planner_ || planner_map_ != ctx.run->map.get()) {
      planner_ = std::make_unique<PathPlanner>(*ctx.run->map, ctx.robot().base.radius_m);
      planner_map_ = ctx.run->map.get();
    }
    return planner_->path_length_m(from, to).value_or(std::numeric_limits<double>::infinity());
  }

  std::string order_;
  std::unique_ptr<PathPlanner> planner_;
  const void* planner_map_ = nullptr;
  bool warned_no_map_ = false;
};

void check_params(const Params& params) {
  const std::string& order = params.string("order");
  if (!order.empty() && order != "mission" && order != "nearest") {
    throw std::invalid_argument("order must be \"mission\" or \"nearest\", not \"" + order + "\"");
  }
}

const projtour_param_desc kParams[] = {
    {"order", "string", "",
     "mission | nearest (by path length on the map); empty = the mission's `order`"}};
const char* const kOutcomes[] = {"succeeded", "finished"};
const projtour_kind_desc kKinds[] = {
    behaviour_kind<Next>("next", "blank, stow the head and choose the next target", kParams,
                         kOutcomes, validator<check_params>())};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("next", "1.0.0", projtour::kKinds)
