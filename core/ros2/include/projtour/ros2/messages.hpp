#pragma once
// ROS 2 messages (the generated C types of idl/) to and from projtour's driver types. Reading
// checks what arrives: a message with a NaN, an infinite or an out-of-range value is refused with
// the reason, never passed on to the robot.
#include <optional>
#include <string>
#include <vector>

#include "builtin_interfaces.h"
#include "geometry_msgs.h"
#include "nav_msgs.h"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/robot.hpp"
#include "projtour/ros2/dds.hpp"
#include "rosgraph_msgs.h"
#include "sensor_msgs.h"
#include "std_msgs.h"

namespace projtour::ros2 {

// The robot file's domain and network choice.
inline NetworkSpec network_of(const Ros2Spec& spec) {
  return {spec.domain_id, spec.loopback_only};
}

// A message refused, and why ("pose.position.x is NaN").
struct Refusal {
  std::string reason;
};

builtin_interfaces_msg_dds__Time_ to_time(double t_s);
double from_time(const builtin_interfaces_msg_dds__Time_& t);

geometry_msgs_msg_dds__Twist_ make_twist(double v_mps, double w_radps);

// The base's integrated odometry. Refused: non-finite values, an orientation that is no unit
// quaternion (|q| off 1 by more than 1e-3) or one tilted off the floor, a frame other than
// ros2.odom_frame / ros2.base_frame.
struct OdometryRead {
  std::optional<Odometry> odometry;
  Refusal refusal;
};
OdometryRead read_odometry(const nav_msgs_msg_dds__Odometry_& msg, const Ros2Spec& spec);

// The message written from projtour's Odometry (the bridge's side). `frame_id`/`child_frame_id`
// point into the strings given, which must outlive the message.
struct OdometryMessage {
  nav_msgs_msg_dds__Odometry_ msg{};
  std::string frame_id, child_frame_id;
};
void fill_odometry(const Odometry& odom, const Ros2Spec& spec, OdometryMessage& out);

// A scan as projtour's driver type: angles ascending (a scan with a negative increment, as from
// a scanner mounted upside down, is reversed), a reading valid when finite and within
// [range_min, range_max]. Refused: non-finite or non-positive increment, range_max <= range_min,
// no readings, more than 100000, a frame other than ros2.laser_frame when one is set.
struct ScanRead {
  std::optional<LaserScan> scan;
  Refusal refusal;
};
ScanRead read_scan(const sensor_msgs_msg_dds__LaserScan_& msg, const Ros2Spec& spec,
                   const Eigen::Isometry3d& T_base_laser);

// Owns the buffers a LaserScan_ message points into.
struct ScanMessage {
  sensor_msgs_msg_dds__LaserScan_ msg{};
  std::string frame_id;
  std::vector<float> ranges;
};
void fill_scan(const LaserScan& scan, const std::string& frame_id, ScanMessage& out);

// The pan and tilt joints by name in a JointState (other joints are ignored). Refused: a
// joint missing or a position non-finite.
struct JointsRead {
  std::optional<JointAngles> angles;
  Refusal refusal;
};
JointsRead read_joints(const sensor_msgs_msg_dds__JointState_& msg, const Ros2Spec& spec);

struct JointStateMessage {
  sensor_msgs_msg_dds__JointState_ msg{};
  std::vector<std::string> names;
  std::vector<char*> name_ptrs;
  std::vector<double> positions;
};
void fill_joint_state(double t_s, const JointAngles& angles, const Ros2Spec& spec,
                      JointStateMessage& out);

// ros2_control's forward position controller command: positions in [pan, tilt] order.
struct JointCommandMessage {
  std_msgs_msg_dds__Float64MultiArray_ msg{};
  std::vector<double> data;
  std::vector<std_msgs_msg_dds__MultiArrayDimension_> dims;
  std::string label = "joints";
};
void fill_joint_command(const JointAngles& angles, JointCommandMessage& out);
std::optional<JointAngles> read_joint_command(const std_msgs_msg_dds__Float64MultiArray_& msg,
                                              Refusal& refusal);

// The estimate on the map as AMCL publishes it (x, y, yaw variances in the 6x6's diagonal).
struct PoseMessage {
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ msg{};
  std::string frame_id = "map";
};
void fill_pose(const PoseEstimate2D& estimate, PoseMessage& out);
PoseEstimate2D read_pose(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& msg);

geometry_msgs_msg_dds__Quaternion_ quaternion_from_yaw(double yaw_rad);

}  // namespace projtour::ros2
