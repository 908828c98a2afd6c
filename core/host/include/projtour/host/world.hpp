#pragma once
// The world file of a dry run: what only the simulator may know (true poses, noise, faults). The
// RunContext carries it as an opaque pointer; the simulated drivers are its only readers.
#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/host/diagnostics.hpp"

namespace projtour::host {

// Faults a dry run injects for one target (world file).
struct FaultSpec {
  std::string target;  // target id
  std::string type;    // one of world_faults.hpp's table, which says its numbers and defaults
  std::map<std::string, double> values;  // the numbers written (fault_number() adds defaults)
  SourceMark mark;
};

// An unmapped object standing on the floor (world file `objects`, and the seeded clutter): the
// laser, the cameras, the projector's light and the bumper meet it; the robot's map never
// shows it.
struct WorldObjectSpec {
  enum class Shape { box, cylinder };
  Shape shape = Shape::box;
  Pose2D pose;            // centre of its footprint, map frame
  double size_x_m = 0.5;  // box: along its own x; cylinder: the diameter
  double size_y_m = 0.5;  // box only
  double height_m = 1.0;  // from the floor
  SourceMark mark;
};

// A straight wall from a to b (map frame), `thickness_m` across.
struct WallSegmentSpec {
  Eigen::Vector2d a_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d b_m = Eigen::Vector2d::Zero();
  double thickness_m = 0.1;
  SourceMark mark;
};

// How the building differs from its map (world file `map_error`). The world's walls are the
// map's, thinned, moved and edited as below; the robot localizes on the unedited map.
struct MapErrorSpec {
  double wall_thinning_m = 0.0;  // each wall face this much farther back (walls keep a cell)
  // The world's walls are the map's turned by rotation_deg about `rotation_about_m` (default:
  // the mission's start, where a map drawn from there is truest), then shifted.
  double shift_x_m = 0.0;
  double shift_y_m = 0.0;
  double rotation_deg = 0.0;
  std::optional<Eigen::Vector2d> rotation_about_m;
  std::vector<WallSegmentSpec> missing_walls;  // on the map, not in the building
  std::vector<WallSegmentSpec> extra_walls;    // in the building, not on the map
  bool any() const {
    return wall_thinning_m > 0.0 || shift_x_m != 0.0 || shift_y_m != 0.0 || rotation_deg != 0.0 ||
           !missing_walls.empty() || !extra_walls.empty();
  }
};

// Seeded clutter along the walls (world file `clutter`): boxes and cylinders against the map's
// walls, `per_m` of them per metre of wall face, kept `keep_clear_m` from every stand-off pose,
// target and the start.
struct ClutterSpec {
  double per_m = 0.0;
  double min_size_m = 0.2;
  double max_size_m = 0.5;
  double min_height_m = 0.3;
  double max_height_m = 1.2;
  double keep_clear_m = 1.0;
};

// One person (world file `people.list`): a cylinder with a head, walking a route of waypoints
// (in order, then back to the first when `loop`), or a seeded random walk when the route is
// empty. People keep out of the robot's way (they stop short of it and go elsewhere), never out
// of its sensors'.
struct PersonSpec {
  std::vector<Eigen::Vector2d> route_m;
  bool loop = true;
  std::optional<Eigen::Vector2d> start_m;  // random walk: where it starts (else seeded)
  double speed_mps = 1.0;
  double pause_s = 0.0;  // at each waypoint
  double start_s = 0.0;  // mission time it appears
  SourceMark mark;
};

struct CrowdSpec {
  int walkers = 0;  // seeded random walkers, besides `list`
  double min_speed_mps = 0.5;
  double max_speed_mps = 1.5;
  double max_pause_s = 3.0;
  double radius_m = 0.25;  // body
  double height_m = 1.7;   // top of the head
  std::vector<PersonSpec> list;
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
  // A fixed encoder offset the robot does not know: measured = true + bias.
  double encoder_bias_pan_deg = 0.0;
  double encoder_bias_tilt_deg = 0.0;
  bool depth_noise = true;       // Kinect-v1 model
  bool depth_artefacts = false;  // its shadows, flying pixels and correlated noise too
  // The robot's copy of each model: decimated and noised resampling of the rendered mesh.
  bool model_error = true;
  double model_error_noise_mm = 1.0;
  // Error of the camera-projector calibration the robot believes in.
  double calibration_error_mm = 1.0;
  double calibration_error_deg = 0.1;
  std::vector<FaultSpec> faults;
  // A building that is not the map.
  std::vector<WorldObjectSpec> objects;
  ClutterSpec clutter;
  bool supports = false;  // every target stands on a plinth or a stand
  MapErrorSpec map_error;
  std::vector<WallSegmentSpec> glass;  // the laser and the depth camera see through these
  CrowdSpec people;
};

}  // namespace projtour::host
