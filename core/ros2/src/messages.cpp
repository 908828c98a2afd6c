#include "projtour/ros2/messages.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace projtour::ros2 {

namespace {

bool finite_all(std::initializer_list<double> values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}

std::string str(const char* s) {
  return s != nullptr ? std::string(s) : std::string();
}

// A frame named in the robot file must be the one the message names; ROS 2 frame ids may carry
// tf2's old leading '/', which names the same frame.
bool same_frame(const std::string& expected, const char* got) {
  std::string g = str(got);
  if (!g.empty() && g.front() == '/') g.erase(0, 1);
  return g == expected;
}

}  // namespace

builtin_interfaces_msg_dds__Time_ to_time(double t_s) {
  builtin_interfaces_msg_dds__Time_ t{};
  const double sec = std::floor(t_s);
  t.sec = static_cast<int32_t>(sec);
  t.nanosec = static_cast<uint32_t>(std::min(999999999.0, std::round((t_s - sec) * 1e9)));
  return t;
}

double from_time(const builtin_interfaces_msg_dds__Time_& t) {
  return static_cast<double>(t.sec) + static_cast<double>(t.nanosec) * 1e-9;
}

geometry_msgs_msg_dds__Quaternion_ quaternion_from_yaw(double yaw_rad) {
  geometry_msgs_msg_dds__Quaternion_ q{};
  q.z = std::sin(yaw_rad / 2);
  q.w = std::cos(yaw_rad / 2);
  return q;
}

geometry_msgs_msg_dds__Twist_ make_twist(double v_mps, double w_radps) {
  geometry_msgs_msg_dds__Twist_ t{};
  t.linear.x = v_mps;
  t.angular.z = w_radps;
  return t;
}

OdometryRead read_odometry(const nav_msgs_msg_dds__Odometry_& msg, const Ros2Spec& spec) {
  OdometryRead r;
  const auto& p = msg.pose.pose.position;
  const auto& q = msg.pose.pose.orientation;
  const auto& v = msg.twist.twist;
  if (!finite_all({p.x, p.y, p.z})) {
    r.refusal.reason = "pose.pose.position is not finite";
  } else if (!finite_all({q.x, q.y, q.z, q.w})) {
    r.refusal.reason = "pose.pose.orientation is not finite";
  } else if (!finite_all({v.linear.x, v.linear.y, v.angular.z})) {
    r.refusal.reason = "twist.twist is not finite";
  }
  if (!r.refusal.reason.empty()) return r;
  if (msg.header.stamp.nanosec >= 1000000000u) {
    r.refusal.reason =
        "header.stamp.nanosec " + std::to_string(msg.header.stamp.nanosec) + " is not below 1e9";
    return r;
  }
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (std::abs(norm - 1.0) > 1e-3) {
    r.refusal.reason =
        "pose.pose.orientation is not a unit quaternion (norm " + std::to_string(norm) + ")";
    return r;
  }
  // A floor robot's odometry turns about z only; a tilt is a broken or misconfigured source.
  const double tilt = 2.0 * std::sqrt(q.x * q.x + q.y * q.y) / norm;
  if (tilt > 0.1) {
    r.refusal.reason = "pose.pose.orientation is tilted off the floor";
    return r;
  }
  if (!same_frame(spec.odom_frame, msg.header.frame_id)) {
    r.refusal.reason = "header.frame_id is \"" + str(msg.header.frame_id) + "\", expected \"" +
                       spec.odom_frame + "\"";
    return r;
  }
  if (!same_frame(spec.base_frame, msg.child_frame_id)) {
    r.refusal.reason = "child_frame_id is \"" + str(msg.child_frame_id) + "\", expected \"" +
                       spec.base_frame + "\"";
    return r;
  }
  Odometry o;
  o.t_s = from_time(msg.header.stamp);
  o.pose.x_m = p.x;
  o.pose.y_m = p.y;
  o.pose.yaw_rad = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
  o.v_mps = v.linear.x;
  o.w_radps = v.angular.z;
  r.odometry = o;
  return r;
}

void fill_odometry(const Odometry& odom, const Ros2Spec& spec, OdometryMessage& out) {
  out.frame_id = spec.odom_frame;
  out.child_frame_id = spec.base_frame;
  out.msg = nav_msgs_msg_dds__Odometry_{};
  out.msg.header.stamp = to_time(odom.t_s);
  out.msg.header.frame_id = out.frame_id.data();
  out.msg.child_frame_id = out.child_frame_id.data();
  out.msg.pose.pose.position.x = odom.pose.x_m;
  out.msg.pose.pose.position.y = odom.pose.y_m;
  out.msg.pose.pose.orientation = quaternion_from_yaw(odom.pose.yaw_rad);
  out.msg.twist.twist = make_twist(odom.v_mps, odom.w_radps);
}

ScanRead read_scan(const sensor_msgs_msg_dds__LaserScan_& msg, const Ros2Spec& spec,
                   const Eigen::Isometry3d& T_base_laser) {
  ScanRead r;
  const std::size_t n = msg.ranges._length;
  if (!finite_all(
          {msg.angle_min, msg.angle_max, msg.angle_increment, msg.range_min, msg.range_max})) {
    r.refusal.reason =
        "angle_min, angle_max, angle_increment, range_min or range_max is not finite";
  } else if (msg.angle_increment == 0.0f) {
    r.refusal.reason = "angle_increment is 0";
  } else if (!(msg.range_max > msg.range_min) || msg.range_min < 0.0f) {
    r.refusal.reason = "range_min " + std::to_string(msg.range_min) + " and range_max " +
                       std::to_string(msg.range_max) + " are no range";
  } else if (n == 0) {
    r.refusal.reason = "ranges is empty";
  } else if (n > 100000) {
    r.refusal.reason = "ranges has " + std::to_string(n) + " readings (at most 100000)";
  } else if (std::abs(static_cast<double>(msg.angle_increment)) * static_cast<double>(n - 1) >
             2.0 * M_PI + 1e-3) {
    r.refusal.reason = "the readings span more than a full turn";
  } else if (msg.header.stamp.nanosec >= 1000000000u) {
    r.refusal.reason = "header.stamp.nanosec is not below 1e9";
  } else if (!spec.laser_frame.empty() && !same_frame(spec.laser_frame, msg.header.frame_id)) {
    r.refusal.reason = "header.frame_id is \"" + str(msg.header.frame_id) + "\", expected \"" +
                       spec.laser_frame + "\"";
  }
  if (!r.refusal.reason.empty()) return r;
  LaserScan s;
  s.t_s = from_time(msg.header.stamp);
  s.max_range_m = msg.range_max;
  s.T_base_laser = T_base_laser;
  s.ranges_m.resize(n);
  s.valid.resize(n);
  const bool reversed = msg.angle_increment < 0.0f;
  const double increment = std::abs(static_cast<double>(msg.angle_increment));
  s.angle_increment_rad = increment;
  s.angle_min_rad = reversed ? msg.angle_min - increment * static_cast<double>(n - 1)
                             : static_cast<double>(msg.angle_min);
  for (std::size_t i = 0; i < n; ++i) {
    const float range = msg.ranges._buffer[reversed ? n - 1 - i : i];
    const bool ok = std::isfinite(range) && range >= msg.range_min && range <= msg.range_max;
    s.ranges_m[i] = ok ? range : 0.0f;
    s.valid[i] = ok ? 1 : 0;
  }
  r.scan = std::move(s);
  return r;
}

void fill_scan(const LaserScan& scan, const std::string& frame_id, ScanMessage& out) {
  out.frame_id = frame_id;
  out.ranges.resize(scan.ranges_m.size());
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    // ROS 2's convention for "no return": +inf (REP 117).
    out.ranges[i] = (i < scan.valid.size() && scan.valid[i])
                        ? scan.ranges_m[i]
                        : std::numeric_limits<float>::infinity();
  }
  out.msg = sensor_msgs_msg_dds__LaserScan_{};
  out.msg.header.stamp = to_time(scan.t_s);
  out.msg.header.frame_id = out.frame_id.data();
  out.msg.angle_min = static_cast<float>(scan.angle_min_rad);
  out.msg.angle_increment = static_cast<float>(scan.angle_increment_rad);
  out.msg.angle_max =
      static_cast<float>(scan.angle_min_rad +
                         scan.angle_increment_rad *
                             static_cast<double>(std::max<std::size_t>(1, out.ranges.size()) - 1));
  out.msg.range_min = 0.0f;
  out.msg.range_max = static_cast<float>(scan.max_range_m);
  out.msg.ranges._length = out.msg.ranges._maximum = static_cast<uint32_t>(out.ranges.size());
  out.msg.ranges._buffer = out.ranges.data();
  out.msg.ranges._release = false;
}

JointsRead read_joints(const sensor_msgs_msg_dds__JointState_& msg, const Ros2Spec& spec) {
  JointsRead r;
  std::optional<double> pan, tilt;
  for (uint32_t i = 0; i < msg.name._length; ++i) {
    const std::string name = str(msg.name._buffer[i]);
    if (name != spec.pan_joint && name != spec.tilt_joint) continue;
    if (i >= msg.position._length) {
      r.refusal.reason = "joint \"" + name + "\" has no position";
      return r;
    }
    const double p = msg.position._buffer[i];
    if (!std::isfinite(p)) {
      r.refusal.reason = "position of joint \"" + name + "\" is not finite";
      return r;
    }
    (name == spec.pan_joint ? pan : tilt) = p;
  }
  if (!pan || !tilt) {
    // A joint_states topic may carry other joints in separate messages (wheels): not an error.
    return r;
  }
  r.angles = JointAngles{*pan, *tilt};
  return r;
}

void fill_joint_state(double t_s, const JointAngles& angles, const Ros2Spec& spec,
                      JointStateMessage& out) {
  out.names = {spec.pan_joint, spec.tilt_joint};
  out.name_ptrs = {out.names[0].data(), out.names[1].data()};
  out.positions = {angles.pan_rad, angles.tilt_rad};
  out.msg = sensor_msgs_msg_dds__JointState_{};
  out.msg.header.stamp = to_time(t_s);
  out.msg.header.frame_id = const_cast<char*>("");
  out.msg.name._length = out.msg.name._maximum = 2;
  out.msg.name._buffer = out.name_ptrs.data();
  out.msg.position._length = out.msg.position._maximum = 2;
  out.msg.position._buffer = out.positions.data();
}

void fill_joint_command(const JointAngles& angles, JointCommandMessage& out) {
  out.data = {angles.pan_rad, angles.tilt_rad};
  out.dims.resize(1);
  out.dims[0].label = out.label.data();
  out.dims[0].size = 2;
  out.dims[0].stride = 2;
  out.msg = std_msgs_msg_dds__Float64MultiArray_{};
  out.msg.layout.dim._length = out.msg.layout.dim._maximum = 1;
  out.msg.layout.dim._buffer = out.dims.data();
  out.msg.data._length = out.msg.data._maximum = 2;
  out.msg.data._buffer = out.data.data();
}

std::optional<JointAngles> read_joint_command(const std_msgs_msg_dds__Float64MultiArray_& msg,
                                              Refusal& refusal) {
  if (msg.data._length != 2) {
    refusal.reason = "data has " + std::to_string(msg.data._length) + " values, expected 2";
    return std::nullopt;
  }
  const double pan = msg.data._buffer[0], tilt = msg.data._buffer[1];
  if (!std::isfinite(pan) || !std::isfinite(tilt)) {
    refusal.reason = "data is not finite";
    return std::nullopt;
  }
  return JointAngles{pan, tilt};
}

void fill_pose(const PoseEstimate2D& estimate, PoseMessage& out) {
  out.msg = geometry_msgs_msg_dds__PoseWithCovarianceStamped_{};
  out.msg.header.stamp = to_time(estimate.t_s);
  out.msg.header.frame_id = out.frame_id.data();
  out.msg.pose.pose.position.x = estimate.mean.x_m;
  out.msg.pose.pose.position.y = estimate.mean.y_m;
  out.msg.pose.pose.orientation = quaternion_from_yaw(estimate.mean.yaw_rad);
  // Row-major 6x6 over (x, y, z, roll, pitch, yaw); (x, y, yaw) is indices 0, 1, 5.
  const int index[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      out.msg.pose.covariance[index[i] * 6 + index[j]] = estimate.covariance(i, j);
    }
  }
}

PoseEstimate2D read_pose(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& msg) {
  PoseEstimate2D e;
  e.t_s = from_time(msg.header.stamp);
  const auto& p = msg.pose.pose.position;
  const auto& q = msg.pose.pose.orientation;
  e.mean = {p.x, p.y,
            std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))};
  const int index[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) e.covariance(i, j) = msg.pose.covariance[index[i] * 6 + index[j]];
  }
  return e;
}

}  // namespace projtour::ros2
