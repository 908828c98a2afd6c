#pragma once
// A run for in-process tests of behaviours, services and drivers: the RunContext the executor
// would build, with every piece it points to owned here, and the Contexts of its states.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/host/world.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::test {

// Keeps every message; prints those at `echo` or above to stderr.
class RecordingLogger : public Logger {
 public:
  explicit RecordingLogger(LogLevel echo = LogLevel::error) : echo_(echo) {}
  void log(LogLevel level, const std::string& message) override;
  // The messages at `at_least` or above, in order.
  std::vector<std::string> messages(LogLevel at_least = LogLevel::debug) const;
  void set_echo(LogLevel echo) { echo_ = echo; }

 private:
  struct Entry {
    LogLevel level;
    std::string message;
  };
  std::vector<Entry> entries_;
  LogLevel echo_;
};

// Not copyable or movable: `run` points into the rig. Declare a PluginRegistry before the rig
// (so it is destroyed after it): blackboard values a plugin stored run that plugin's code when
// they are destroyed.
class RunRig {
 public:
  // Where the run's files go: a TempDir, or nowhere (run_dir empty: the executor then makes no
  // target directories, as the in-process executor tests and benchmarks want).
  enum class RunDir { temp, none };

  // A dry run (seed 1) of an empty mission, no world, no drivers, the clock at 0.
  explicit RunRig(RunDir run_dir = RunDir::temp);
  RunRig(const RunRig&) = delete;
  RunRig& operator=(const RunRig&) = delete;

  // run.world = &world (a dry run's simulated drivers read it).
  void use_world() { run.world = &world; }

  // A state's view with `params` (may be null) and no target.
  Context context(const Params* params = nullptr, const std::string& state_path = "test") const;
  // The same at target `index` of the mission, its directory run_dir/targets/<id> created.
  Context target_context(std::size_t index, const Params* params = nullptr,
                         const std::string& state_path = "test") const;

  // Advances the clock by dt_s and updates every driver at the new time, as the executor's tick.
  void advance(double dt_s);
  // Sets the clock to t_s and updates every driver at it.
  void advance_to(double t_s);

  MissionSpec mission;
  host::WorldSpec world;
  DriverSet drivers;
  Blackboard blackboard;
  SteppedClock clock;
  RecordingLogger log;
  CancelToken cancel;
  std::optional<TempDir> dir;
  RunContext run;
};

}  // namespace projtour::test
