#pragma once
// The world file of a dry run: what only the simulator may know (true poses, noise, faults). The
// RunContext carries it as an opaque pointer; the simulated drivers are its only readers.
#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour/diagnostics.hpp"

namespace projtour {

// Faults a dry run injects for one target (world file).
struct FaultSpec {
  std::string target;  // target id
  std::string type;    // frame_dropout | target_missing | occluder | blocked_path | kidnap |
                       // camera_disconnect | projector_failure | target_nudge | pole |
                       // daylight
                       // (pole's numbers are checked when loaded: distance_m > 0,
                       // diameter_m > 0, offset_m; all documented in atrium_faults.yaml)
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
