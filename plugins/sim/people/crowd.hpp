#pragma once
// Inside the sim plugin: the people walking through the building (world file `people`, and the
// scripted walkers the person faults add). The laser, the cameras, the light and the bumper meet
// them; they keep out of the robot's way, never out of its sensors'.
#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "bodies/building.hpp"
#include "projtour/host/world.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour::sim {

// The people walking through the building. Deterministic: every draw comes from the stream
// handed in.
class Crowd {
 public:
  // `walls` (the building's, with glass) and `objects` bound where people can walk; random
  // walkers roam about `homes` (points on the tour), starting at seeded free spots near them.
  Crowd(const host::CrowdSpec& spec, const mrpt::maps::COccupancyGridMap2D* walls,
        const std::vector<Footprint>& objects, const std::vector<Eigen::Vector2d>& homes,
        int first_object_id, std::uint64_t seed);

  // A person walking `route` once from mission time start_s, standing `pause_s` at each
  // waypoint, then gone: what the world's person_standing and person_crossing faults add.
  void add_scripted(const std::vector<Eigen::Vector2d>& route, const std::vector<double>& pause_s,
                    double speed_mps, double start_s);

  // Moves everyone by dt_s to mission time t_s. Nobody steps to within keep_off_m of the
  // robot's centre (minus their radius): they stop, and after a while walk elsewhere.
  void step(double t_s, double dt_s, const Eigen::Vector2d& robot_m, double keep_off_m);

  // The people present now, as the scene's moving layer.
  const std::vector<PersonShape>& shapes() const { return shapes_; }
  bool moved() const { return moved_; }
  std::size_t size() const { return people_.size(); }
  // Where each person present now stands (for the tracks in tour.png), by index.
  std::vector<std::pair<int, Eigen::Vector2d>> positions() const;

 private:
  struct Person {
    Eigen::Vector2d at_m = Eigen::Vector2d::Zero();
    std::vector<Eigen::Vector2d> route_m;  // scripted or listed; empty: random walk
    std::vector<double> pause_s;           // per waypoint (scripted)
    std::size_t next = 0;                  // waypoint walked to
    bool loop = false;
    bool scripted = false;  // walks its route once, then is gone
    Eigen::Vector2d goal_m = Eigen::Vector2d::Zero();
    Eigen::Vector2d home_m = Eigen::Vector2d::Zero();
    double speed_mps = 1.0;
    double pause_each_s = 0.0;
    double start_s = 0.0;
    double paused_until_s = 0.0;
    double blocked_s = 0.0;  // how long the robot has stood in its way
    bool present = false;
    bool gone = false;
    int object_id = 0;
  };
  bool walkable(const Eigen::Vector2d& p) const;
  bool line_walkable(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const;
  void choose_goal(Person& p);
  void update_shapes();

  host::CrowdSpec spec_;
  std::vector<Person> people_;
  std::vector<PersonShape> shapes_;
  std::vector<Eigen::Vector2d> homes_;
  // Free for a person's centre: the walls and objects grown by the person's radius.
  std::vector<std::uint8_t> free_;
  int cols_ = 0, rows_ = 0;
  double x_min_m_ = 0.0, y_min_m_ = 0.0, resolution_m_ = 1.0;
  int first_object_id_ = 0;
  std::mt19937_64 rng_;
  bool moved_ = false;
};

}  // namespace projtour::sim
