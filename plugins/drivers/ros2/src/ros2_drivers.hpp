#pragma once
// The ros2 drivers: a base, a laser and a pan-tilt reached over ROS 2 topics (DDS), named and
// set up by the robot file's ros2 section.
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/ros2/dds.hpp"
#include "projtour/ros2/messages.hpp"

namespace projtour::ros2 {

using SteadyClock = std::chrono::steady_clock;

// What a reader that heard nothing usable can say: the last message it refused and why, or the
// types others publish on its topic when none is ours, or that nobody publishes it at all.
std::string silence_reason(const Participant& p, const std::string& dds_topic,
                           const std::string& expected_type, const std::string& last_refusal);

// Publishes cmd_vel and reads odom. Stops the robot (zero Twists, ros2.stop_repeats of them) on
// safe_stop and on destruction, and when no valid odometry arrived for ros2.odom_timeout_s: then
// it throws DriverError from update() (the executor fails the active state with it, an outcome
// the machine handles) and from every command until valid odometry is heard again, so a robot
// never drives blind.
//
// In a dry run it is the tour's half of the simulator split across processes
// (projtour-sim-ros2 runs the base and the laser): each update(t) publishes the mission time on
// /clock, waits for the odometry of that instant, and sets this process's world to the bridge's
// true base pose (published on /projtour_sim/true_pose), so the cameras and the projector here
// see from where the base truly is.
class Ros2Base : public BaseDriver {
 public:
  Ros2Base(const Params& params, const RunContext& run);
  ~Ros2Base() override;
  void update(double t_s) override;
  void safe_stop() override;
  void command_velocity(double v_mps, double w_radps) override;
  Odometry odometry() const override;

 private:
  void drain_odometry();
  bool wait_for_first_odometry(double timeout_s);
  bool wait_for_odometry(double at_least_t_s, double timeout_s);
  void stop_and_fail(const std::string& why);
  [[noreturn]] void throw_failed() const;

  const RunContext& run_;
  const Ros2Spec spec_;
  Participant participant_;
  Writer<geometry_msgs_msg_dds__Twist_> cmd_vel_;
  Reader<nav_msgs_msg_dds__Odometry_> odom_;
  std::unique_ptr<Writer<rosgraph_msgs_msg_dds__Clock_>> clock_;        // dry run only
  std::unique_ptr<Reader<geometry_msgs_msg_dds__PoseStamped_>> truth_;  // dry run only
  mutable std::mutex mutex_;
  std::optional<Odometry> odometry_;
  SteadyClock::time_point last_odometry_wall_;
  std::string last_refusal_;
  long refused_ = 0;
  std::optional<std::string> failed_;
};

// Reads sensor_msgs/LaserScan from scan: the newest valid scan, placed by the robot file's laser
// pose. Refused scans (NaN angles, no range, wrong frame) are dropped and counted; the first
// refusal of each kind is logged.
class Ros2Laser : public LaserDriver {
 public:
  Ros2Laser(const Params& params, const RunContext& run);
  void safe_stop() override {}
  std::optional<LaserScan> take_scan() override;

 private:
  const RunContext& run_;
  const Ros2Spec spec_;
  Participant participant_;
  Reader<sensor_msgs_msg_dds__LaserScan_> scan_;
  std::string last_refusal_;
};

// Commands positions as std_msgs/Float64MultiArray [pan, tilt] (ros2_control's forward position
// controller) and reads the joints from sensor_msgs/JointState by the robot file's joint names.
// No joint state for ros2.odom_timeout_s after the first: DriverError.
class Ros2PanTilt : public PanTiltDriver {
 public:
  Ros2PanTilt(const Params& params, const RunContext& run);
  void update(double t_s) override;
  void safe_stop() override;
  void command(const JointAngles& angles) override;
  JointAngles measured() const override;
  bool reached() const override;

 private:
  void drain();

  const RunContext& run_;
  const Ros2Spec spec_;
  double tolerance_rad_;
  Participant participant_;
  Writer<std_msgs_msg_dds__Float64MultiArray_> command_;
  Reader<sensor_msgs_msg_dds__JointState_> joint_states_;
  mutable std::mutex mutex_;
  JointAngles measured_, previous_, commanded_;
  bool has_command_ = false;
  bool has_measurement_ = false;
  SteadyClock::time_point last_state_wall_;
  std::string last_refusal_;
};

}  // namespace projtour::ros2
