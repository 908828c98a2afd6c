#pragma once
// The tour's status on ROS 2 (DDS), under the robot's namespace, for a dashboard or a fleet
// manager (README "ROS 2"): published when it changes, transient local so a late joiner sees
// the present state at once.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/context.hpp"
#include "projtour/machine/executor.hpp"

namespace projtour {

class Ros2Status {
 public:
  // Opens the topics; throws ros2::DdsError when DDS cannot be reached (the run ends unmoved).
  Ros2Status(const Executor& executor, const RunContext& run);
  ~Ros2Status();
  // Once a tick: writes what changed since the last call.
  void publish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Whether this run publishes its status: a ROS 2 robot (a robot file with a ros2 section, or a
// ros2_* driver in the run, as in a dry run over the bridge) whose ros2.publish_status is on.
// A plain dry run has only simulated drivers, so it never opens DDS.
bool wants_ros2_status(const RunContext& run, const std::vector<std::string>& driver_kinds);

}  // namespace projtour
