#pragma once
// Inside the sim plugin: what stands in the building, and what meets it. The walls (the bumper's
// grid with the glass, the laser's without), the unmapped objects' footprints, the fault
// obstacles, the rendered scene, and the two questions asked of them all: does the robot's body
// touch anything here (the bumper), and how far does each laser ray reach. People are handed in
// as the scene's moving layer: they are people/crowd.hpp's.
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "bodies/building.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/robot.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

struct Box2 {
  Eigen::Vector2d lo, hi;
};

struct WorldBodies {
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> grid;  // the map plus added obstacles
  // The building (building.hpp). `grid` holds its walls, glass included (the bumper's);
  // `laser_grid` the same without the glass (what the laser and the cameras see).
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> laser_grid;
  std::vector<Footprint> footprints;  // unmapped objects: laser, bumper, referee
  std::vector<Footprint> glass;       // the bumper's only
  std::vector<Box2> obstacles;        // blocked_path boxes and poles, for the bumper
  double robot_radius_m = 0.35;
  SceneBuilder fixed_parts;  // floor, walls and obstacles: all the scene but the targets
  Scene scene;
  std::uint64_t scene_version = 0;  // counts rebuilds: the colour camera keeps geometry per scene

  // Does the base at `p` touch an object, glass or a person (at the robot's radius), a fault
  // obstacle or a wall (at `collision_radius_m`)?
  bool collides(const Pose2D& p, double collision_radius_m,
                const std::vector<PersonShape>* people) const;
  // The laser's scan from the base at `p`: walls, unmapped objects and people, with noise of
  // `noise_m` from `rng`.
  LaserScan simulate_scan(const LaserSpec& spec, double t_s, const Pose2D& p, float threshold,
                          double noise_m, const std::vector<PersonShape>* people,
                          std::mt19937_64& rng) const;
  // Per ray of `scan`, the range to the nearest unmapped object or person in the laser's plane
  // (infinity where none); empty when the building has none.
  std::vector<double> unmapped_ranges(const LaserScan& scan, const Pose2D& base,
                                      const std::vector<PersonShape>* people) const;
};

}  // namespace projtour::sim
