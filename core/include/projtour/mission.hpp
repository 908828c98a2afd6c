#pragma once
// The mission file (and the robot and world files it pulls in) as typed structs.
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour/diagnostics.hpp"
#include "projtour/geometry.hpp"
#include "projtour/robot.hpp"

namespace projtour {

struct TargetSpec {
  std::string id;
  std::filesystem::path model;
  Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
  // Corners of the projection area in the model frame: top-left, top-right, bottom-right,
  // bottom-left (the content image's corners go to them in this order).
  std::array<Eigen::Vector3d, 4> model_points;
  std::filesystem::path content;
  double standoff_m = 1.0;
  double dwell_s = 10.0;
};

// Where the state machine comes from: the built-in default, or YAML (inline or a file).
struct MachineSource {
  bool is_default = true;
  YAML::Node node;  // the machine mapping when not default
  std::string file;  // the file the node came from
  std::string path;  // its field path ("machine" inline, "" when a file of its own)
};

struct MissionSpec {
  std::string name;
  std::filesystem::path file;
  std::filesystem::path map;
  std::filesystem::path robot_file;
  Pose2D start;
  std::vector<TargetSpec> targets;
  std::string order = "mission";  // "mission" | "nearest"
  MachineSource machine;
  RobotSpec robot;
  // Where each field was written, by field path ("start", "targets[2].pose", ...), so checks
  // made after loading (map, reachability, plugins) can point at the line.
  std::map<std::string, SourceMark> marks;

  SourceMark mark_of(const std::string& field_path) const;
};

// Faults a dry run injects for one target (world file).
struct FaultSpec {
  std::string target;  // target id
  std::string type;  // frame_dropout | target_missing | occluder | blocked_path | kidnap |
                     // camera_disconnect | projector_failure
  std::map<std::string, double> values;  // type-specific numbers (fraction, distance_m, ...)
  SourceMark mark;
};

// The simulated world of a dry run: the truth, the noise and the faults.
struct WorldSpec {
  std::filesystem::path file;  // empty when defaulted
  std::optional<unsigned long long> seed;
  // True target poses by id; targets not listed sit at the mission's nominal pose moved by a
  // seeded offset within the bounds below (zero bounds = exactly nominal).
  std::map<std::string, Eigen::Isometry3d> T_map_model_true;
  double target_offset_max_m = 0.0;
  double target_offset_max_deg = 0.0;
  // Odometry drift as a fraction of distance travelled / angle turned.
  double odometry_trans_noise_frac = 0.03;
  double odometry_rot_noise_frac = 0.03;
  double laser_range_noise_m = 0.01;
  double encoder_noise_deg = 0.02;
  bool depth_noise = true;  // Kinect-v1 model
  // The robot's copy of each model: decimated and noised resampling of the rendered mesh.
  bool model_error = true;
  double model_error_noise_mm = 1.0;
  // Error of the camera-projector calibration the robot believes in.
  double calibration_error_mm = 1.0;
  double calibration_error_deg = 0.1;
  std::vector<FaultSpec> faults;
};

}  // namespace projtour
