#pragma once
// Everything a behaviour or service may use of the run. Built by the executor; plugins never
// see the executor itself.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/contract/params.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour {

namespace host {
// Only the simulated drivers read the world (host's world.hpp); everyone else sees a pointer.
struct WorldSpec;
}  // namespace host

class CancelToken {
 public:
  bool requested() const { return requested_.load(); }
  void request() { requested_.store(true); }
  void reset() { requested_.store(false); }

 private:
  std::atomic<bool> requested_{false};
};

// Mission time one state has been active, pauses left out. The executor keeps one for the leaf
// it ticks (restarted on entry, held while paused) so that a pause never counts towards a
// behaviour's timeout or no-progress limit.
class StateTimer {
 public:
  void restart(double now_s) {
    entered_s_ = now_s;
    paused_s_ = 0.0;
    paused_ = false;
  }
  void pause(double now_s) {
    if (paused_) return;
    paused_ = true;
    paused_since_s_ = now_s;
  }
  void resume(double now_s) {
    if (!paused_) return;
    paused_ = false;
    paused_s_ += now_s - paused_since_s_;
  }
  bool paused() const { return paused_; }
  // Written as (end - entered) - paused so that, with no pause, it is exactly the mission time
  // since entry (no rounding of its own).
  double elapsed_s(double now_s) const {
    return ((paused_ ? paused_since_s_ : now_s) - entered_s_) - paused_s_;
  }

 private:
  double entered_s_ = 0.0;
  double paused_s_ = 0.0;        // finished pauses
  double paused_since_s_ = 0.0;  // start of the pause in progress
  bool paused_ = false;
};

// Fixed for the whole run.
struct RunContext {
  const MissionSpec* mission = nullptr;
  const host::WorldSpec* world = nullptr;  // dry run only
  bool dry_run = false;
  std::uint64_t seed = 1;
  std::filesystem::path run_dir;
  std::shared_ptr<const mrpt::maps::COccupancyGridMap2D> map;
  DriverSet* drivers = nullptr;
  Blackboard* blackboard = nullptr;
  const Clock* clock = nullptr;
  Logger* log = nullptr;
};

// One state's view: the run, the current target and the state's parameters.
struct Context {
  const RunContext* run = nullptr;
  const TargetSpec* target = nullptr;  // null outside a for_each over targets
  std::size_t target_index = 0;
  std::filesystem::path target_dir;  // run_dir/targets/<id>, created by the executor
  const Params* params = nullptr;
  const CancelToken* cancel = nullptr;
  std::string state_path;  // "tour/visit/align"
  // The active state's timer, owned by the executor; null for services and for a behaviour a
  // test ticks by hand.
  const StateTimer* state_timer = nullptr;

  const MissionSpec& mission() const { return *run->mission; }
  const RobotSpec& robot() const { return run->mission->robot; }
  DriverSet& drivers() const { return *run->drivers; }
  Blackboard& blackboard() const { return *run->blackboard; }
  double now_s() const { return run->clock->now_s(); }
  // Mission time this state has been active, pauses excluded: 0 at start(), frozen while
  // paused. What every timeout and no-progress check measures, as differences of it, so that
  // without a timer (null state_timer: no executor, hence no pause) the fallback to mission time
  // measures the same intervals.
  double state_elapsed_s() const {
    return state_timer != nullptr ? state_timer->elapsed_s(now_s()) : now_s();
  }
  Logger& log() const { return *run->log; }
  bool cancel_requested() const { return cancel != nullptr && cancel->requested(); }
};

}  // namespace projtour
