#pragma once
// Between the runner and the live monitor: starting it as the options ask, the frames it shows,
// and the snapshot the tick loop publishes.
#include <cstdint>
#include <iosfwd>
#include <memory>

#include "projtour/contract/drivers.hpp"
#include "projtour/machine/executor.hpp"
#include "projtour/tour/runner.hpp"
#include "projtour/views/monitor.hpp"

namespace projtour {

// The monitor RunOptions ask for, serving; null when it is off. Throws std::runtime_error when
// one asked for cannot be served (the run ends before anything moves); the default monitor of
// a run on hardware is only warned about then. Writes the token to run_dir/monitor_token (0600)
// and says where the monitor is on `err`.
std::unique_ptr<MonitorServer> start_monitor(const RunOptions& options, const PreparedRun& prepared,
                                             const std::filesystem::path& run_dir,
                                             std::ostream& err);

// The projector's and the colour camera's frames, as they pass, for the monitor to show.
void tap_frames(DriverSet& drivers, MonitorServer& monitor);

// Builds each tick's snapshot, copying what changed only (the plan, the records, a new depth
// frame) so that publishing costs the tick loop next to nothing.
class MonitorPublisher {
 public:
  MonitorPublisher(MonitorServer& monitor, const Executor& executor, const RunContext& run);
  void publish();

 private:
  MonitorServer& monitor_;
  const Executor& executor_;
  const RunContext& run_;
  std::uint64_t seen_writes_ = ~std::uint64_t{0};
  std::uint64_t depth_sequence_ = ~std::uint64_t{0};
  std::shared_ptr<const std::vector<Pose2D>> plan_;
  std::shared_ptr<const std::vector<TargetRecord>> records_;
};

}  // namespace projtour
