#pragma once
// Everything a behaviour or service may use of the run. Built by the executor; plugins never
// see the executor itself.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>

#include "projtour/blackboard.hpp"
#include "projtour/clock.hpp"
#include "projtour/drivers.hpp"
#include "projtour/logger.hpp"
#include "projtour/mission.hpp"
#include "projtour/params.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour {

// Only the simulated drivers read the world (host's world.hpp); everyone else sees a pointer.
struct WorldSpec;

class CancelToken {
 public:
  bool requested() const { return requested_.load(); }
  void request() { requested_.store(true); }
  void reset() { requested_.store(false); }

 private:
  std::atomic<bool> requested_{false};
};

// Fixed for the whole run.
struct RunContext {
  const MissionSpec* mission = nullptr;
  const WorldSpec* world = nullptr;  // dry run only
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

  const MissionSpec& mission() const { return *run->mission; }
  const RobotSpec& robot() const { return run->mission->robot; }
  DriverSet& drivers() const { return *run->drivers; }
  Blackboard& blackboard() const { return *run->blackboard; }
  double now_s() const { return run->clock->now_s(); }
  Logger& log() const { return *run->log; }
  bool cancel_requested() const { return cancel != nullptr && cancel->requested(); }
};

}  // namespace projtour
