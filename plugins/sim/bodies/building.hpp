#pragma once
// Inside the sim plugin: the building that is not the map. Its walls (the map's, edited by the
// world file's map error), the unmapped objects standing in it (listed, seeded clutter, target
// supports); its people are people/crowd.hpp's. The laser, the cameras and the bumper meet all
// of it; the robot's map shows none of it.
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "projtour/host/world.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour::sim {

// An object's footprint on the floor, and the heights it spans: what the laser's plane, the
// bumper and the referee's clearance meet.
struct Footprint {
  enum class Shape { rect, circle };
  Shape shape = Shape::rect;
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();
  double yaw_rad = 0.0;                                      // rect: its x axis in the map
  Eigen::Vector2d half_m = Eigen::Vector2d::Constant(0.25);  // rect: half sizes; circle: x = radius
  double z_min_m = 0.0;
  double z_max_m = 1.0;
  std::string name;  // for the referee: "object 2", "clutter 17", "support of sign", "glass 0"

  // Distance from p to the footprint's edge (negative inside).
  double distance_m(const Eigen::Vector2d& p) const;
  // Ray parameter of the first crossing of origin + t * dir (dir unit), or +inf.
  double ray_hit_m(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir) const;
};

// Where a point of the building is drawn on the map: the map is the building moved back by the
// map error's shift and turned back by its rotation (about `about_m` unless the error names a
// point).
Eigen::Vector2d map_point_of(const Eigen::Vector2d& building_m, const host::MapErrorSpec& error,
                             const Eigen::Vector2d& about_m);

// The building's walls as a grid like the map: the map turned and shifted, its walls thinned
// (each keeps its middle cell), walls missing from the building cleared and extra ones drawn.
// `about_m` is where the rotation turns when the map error names no point.
std::shared_ptr<mrpt::maps::COccupancyGridMap2D> building_walls(
    const mrpt::maps::COccupancyGridMap2D& map, const host::MapErrorSpec& error,
    const Eigen::Vector2d& about_m);
// Sets the cells within half the segment's thickness of it to `free_p` (1 free, 0 occupied).
void paint_segment(mrpt::maps::COccupancyGridMap2D& grid, const host::WallSegmentSpec& wall,
                   float free_p);
// A vertical prism around the z axis from z = 0 up to height_m, its corners on the circle of
// radius_m.
perception::TriangleMesh prism_mesh(double radius_m, double height_m, int sides);
// A glass pane as the bumper meets it.
Footprint glass_footprint(const host::WallSegmentSpec& wall, const std::string& name);
Footprint object_footprint(const host::WorldObjectSpec& object, const std::string& name);
// Adds the object to the depth scene (a box, or a 16-sided prism).
void add_object(SceneBuilder& builder, const host::WorldObjectSpec& object, int object_id);

// Seeded clutter against the walls of `walls` (the building's), kept clear of `keep_clear`
// points and of corridors too narrow to leave a robot of `robot_radius_m` by.
std::vector<host::WorldObjectSpec> place_clutter(const mrpt::maps::COccupancyGridMap2D& walls,
                                                 const host::ClutterSpec& spec,
                                                 const std::vector<Eigen::Vector2d>& keep_clear,
                                                 double robot_radius_m, std::mt19937_64& rng);

// What a target stands on, from its true mesh in the map frame: nothing when it is within 5 cm
// of the floor; a plinth under a solid object; two thin posts under a flat one (a sign).
// What a target itself takes up on the floor, for people to walk round (a sign on posts is
// wider than its posts).
std::optional<Footprint> target_footprint(const perception::TriangleMesh& mesh,
                                          const Eigen::Isometry3d& T_map_model,
                                          const std::string& name);
std::vector<host::WorldObjectSpec> target_supports(const perception::TriangleMesh& mesh,
                                                   const Eigen::Isometry3d& T_map_model);

}  // namespace projtour::sim
