#pragma once
// Occupancy grids (MRPT's COccupancyGridMap2D: cell value 1.0 free, 0.0 occupied).
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/mission.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour::navigation {

// ROS map_server YAML (+ PGM/PNG) or MRPT .gridmap / .gridmap.gz. Throws std::runtime_error
// naming the file when it cannot be read.
std::shared_ptr<mrpt::maps::COccupancyGridMap2D> load_occupancy_grid(
    const std::filesystem::path& file);

// Writes the grid as ROS map_server YAML plus a trinary PNG beside it (same stem): occupied 0,
// free 254, unknown 205, as map_saver does. The grid's lower-left corner becomes the origin.
void save_occupancy_grid_yaml(const mrpt::maps::COccupancyGridMap2D& map,
                              const std::filesystem::path& yaml_file);

// The stand-off pose for a target: standoff_m in front of it along its model +x axis projected
// on the floor, facing the target.
Pose2D standoff_pose(const TargetSpec& target);

// One way a mission does not fit its map, by the mission field it concerns.
struct MapProblem {
  std::string field_path;     // "start", "targets[2].standoff_m"
  std::string fallback_path;  // where to point when field_path was not written ("targets[2].pose")
  std::string message;
};

// Checks against the map that every target lies on it, and that the start pose and every
// stand-off pose are in free space reachable from the start (grid inflated by the robot's
// radius). The host turns each problem into a diagnostic at the field's line and column.
std::vector<MapProblem> check_mission_on_map(const MissionSpec& mission,
                                             const mrpt::maps::COccupancyGridMap2D& map);

}  // namespace projtour::navigation
