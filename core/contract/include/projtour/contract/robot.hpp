#pragma once
// The robot file as plugins see it: kinematic chain and sensors. Which driver and service kinds
// run them is the host's (LoadedRobot).
#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/pinhole.hpp"

namespace projtour {

enum class Link { pan, tilt };

struct MountSpec {
  Link link = Link::pan;
  // Device body frame (x along the optical axis, y left, z up) on its link.
  Eigen::Isometry3d T_link_body = Eigen::Isometry3d::Identity();
};

struct BaseSpec {
  double radius_m = 0.35;
  double max_speed_mps = 0.5;
  double max_turn_rate_dps = 60.0;
};

struct LaserSpec {
  Eigen::Isometry3d T_base_laser = Eigen::Isometry3d::Identity();
  double fov_deg = 270.0;
  int rays = 541;
  double max_range_m = 20.0;
  double range_noise_m = 0.01;
  double rate_hz = 10.0;
};

struct PanTiltSpec {
  // Pan joint frame on the base: pan rotates about its z axis.
  Eigen::Isometry3d T_base_pan0 = Eigen::Isometry3d::Identity();
  // Tilt joint frame on the pan link: tilt rotates about its y axis (positive = nose down,
  // as a right-handed rotation about y; the sign is documented in the robot file).
  Eigen::Isometry3d T_pan_tilt0 = Eigen::Isometry3d::Identity();
  double pan_min_deg = -170, pan_max_deg = 170;
  double tilt_min_deg = -30, tilt_max_deg = 60;
  double max_rate_dps = 60.0;
  double encoder_noise_deg = 0.02;
  double stow_pan_deg = 0.0, stow_tilt_deg = 0.0;
  double tolerance_deg = 0.2;  // "reached" when within this of the command
};

// The Kinect v1 colour camera (defaults: 640x480, Burrus' calibration of its lens). Its optical
// frame is the robot's `camera` frame; the depth camera sits at +depth_to_color_m in it
// (p_camera = p_depth + depth_to_color_m).
struct ColourCameraSpec {
  PinholeModel intrinsics{
      640, 480, 525.0, 525.0, 319.5, 239.5, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}};
  double rate_hz = 30.0;
};

struct CameraSpec {
  MountSpec mount;  // of the colour optical frame (the depth frame is registered into it)
  PinholeModel intrinsics;
  // Offset from the depth optical frame to the colour optical frame (the paper's eq. 2: 5 cm
  // along x), applied when building the cloud; zero when depth is registered to colour.
  Eigen::Vector3d depth_to_color_m = Eigen::Vector3d::Zero();
  double min_range_m = 0.4;
  double max_range_m = 4.0;
  double rate_hz = 30.0;
  ColourCameraSpec colour;
};

// The self-calibration's Gray-code sequence (the calibrate step): its length follows from the
// projector's size and block_px, 2 * (ceil(log2(w / block)) + ceil(log2(h / block))) + 2 frames.
struct StructuredLightSpec {
  int block_px = 16;  // the finest stripe, in projector pixels (the camera must resolve it)
  double hold_s = 1.0 / 30.0;    // each pattern is lit this long before its frame counts
  double exposure_ms = 20.0;     // fixed colour exposure during the sequence (0 = automatic)
  int min_correspondences = 40;  // fewer decoded blocks on the target: too_few_points
  double max_residual_px = 1.5;  // larger RMS reprojection error in the projector: poor_fit
};

// The robot file's `ros2:` section: how the ros2_* drivers and the tour's status reach ROS 2 over
// DDS. Absent (present = false), nothing in the run opens DDS. Names are ROS 2 names, relative
// to `ros2_namespace` unless they start with '/'; on the wire a topic is "rt" + its full name.
struct Ros2TopicSpec {
  std::string name;
  bool reliable = true;  // false: best effort, as ROS 2's "sensor data" profile
  int depth = 10;        // keep-last history depth
};

struct Ros2Spec {
  bool present = false;        // the section is written; the tour's status is published only then
  int domain_id = 0;           // unless written, ROS_DOMAIN_ID (as ROS 2), else 0
  std::string ros2_namespace;  // "" or "/ud1"
  // Cyclone DDS on the loopback interface only, discovery by unicast to 127.0.0.1: simulation
  // and tests, where nothing may leave the machine. Off: Cyclone's own choice (CYCLONEDDS_URI).
  // Unless written, ROS_LOCALHOST_ONLY=1 turns it on (as ROS 2).
  bool loopback_only = false;
  Ros2TopicSpec cmd_vel{"cmd_vel", true, 10};
  Ros2TopicSpec odom{"odom", true, 10};
  Ros2TopicSpec scan{"scan", false, 5};
  Ros2TopicSpec joint_states{"joint_states", true, 10};
  // ros2_control's forward position controller: std_msgs/Float64MultiArray in joint order.
  Ros2TopicSpec pan_tilt_command{"pan_tilt_controller/commands", true, 10};
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  std::string laser_frame;  // "" = whatever frame the scans name
  std::string pan_joint = "pan_joint";
  std::string tilt_joint = "tilt_joint";
  // No odometry for this long (wall seconds on hardware) and the base driver stops the robot
  // and fails: a robot never drives on odometry it no longer has.
  double odom_timeout_s = 0.5;
  int stop_repeats = 5;  // zero Twists sent on a safe stop, so one lost on the way does no harm
  bool publish_status = true;  // the tour's state, pose, projector and results (README)
};

struct ProjectorSpec {
  MountSpec mount;
  PinholeModel intrinsics;
};

struct RobotSpec {
  std::string name;
  std::filesystem::path file;
  BaseSpec base;
  LaserSpec laser;
  PanTiltSpec pan_tilt;
  CameraSpec camera;
  ProjectorSpec projector;
  StructuredLightSpec structured_light;
  Ros2Spec ros2;
};

}  // namespace projtour
