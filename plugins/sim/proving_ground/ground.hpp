#pragma once
// The proving ground: random buildings the closed loop was not tuned on. A seed draws missions
// (targets from several meshes at random free places on several maps, random stand-offs and
// content areas) and their worlds (calibration error, model error, target offsets, people and
// clutter); each visit carries the factors it was drawn with, so a batch's table can be cut by
// any of them. Same seed, same files, byte for byte.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace projtour::ground {

// A mesh the generator may stand in a building. `held_out` meshes appear only in held-back
// cases: nothing is tuned on them.
struct MeshSource {
  std::string name;
  std::filesystem::path file;  // PLY or OFF with faces
  bool held_out = false;
  bool scale_to_size = true;  // scanned meshes in arbitrary units; the shipped ones are metres
  // The height of the model's origin, for the shipped meshes as the demo tour stands them (a
  // pillar stands on the floor); scanned ones stand on a support 0.4-1.0 m high.
  std::optional<double> origin_height_m;
};

struct MapSource {
  std::string name;
  std::filesystem::path file;  // ROS map_server YAML
};

struct GroundOptions {
  std::uint64_t seed = 1;
  int missions = 10;
  int targets_per_mission = 3;
  std::filesystem::path source_dir;        // the repository (maps, robot, content, shipped meshes)
  std::filesystem::path scanned_mesh_dir;  // CGAL's data/meshes, extracted; empty: shipped only
};

// What one visit was drawn with: the table's factors.
struct VisitFactors {
  std::string mission;  // the case's directory name
  std::string target;
  std::string half;  // "tuning" or "held_back"
  std::string map;
  std::string mesh;
  double standoff_m = 0.0;
  double content_size_m = 0.0;        // the content area's side
  double content_curvature_mm = 0.0;  // the Model Points' distance from their best plane
  double calibration_error_mm = 0.0;
  double calibration_error_deg = 0.0;
  double model_error_mm = 0.0;
  double target_offset_m = 0.0;
  double target_offset_deg = 0.0;
  int people = 0;
  bool clutter = false;
  double tolerance_mm = 0.0;
};

// One mission and its world, as the files the generator writes.
struct GroundCase {
  std::string name;  // "case-0007"
  std::uint64_t seed = 1;
  std::string mission_yaml;
  std::string world_yaml;
  std::vector<VisitFactors> visits;
};

std::vector<MeshSource> default_meshes(const GroundOptions& options);
std::vector<MapSource> default_maps(const GroundOptions& options);

// Draws the cases and writes each mesh it scaled into `mesh_out_dir` (the missions name them).
// Throws std::runtime_error naming what it could not read or place.
std::vector<GroundCase> generate_ground(const GroundOptions& options,
                                        const std::filesystem::path& mesh_out_dir);

// Writes <out>/<case>/mission.yaml, world.yaml and <out>/visits.csv (one row per visit); the
// meshes go to <out>/meshes. Refuses an `out` that exists and is not empty.
void write_ground(const GroundOptions& options, const std::filesystem::path& out);

}  // namespace projtour::ground
