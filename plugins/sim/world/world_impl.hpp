#pragma once
// Inside the sim plugin: the world's parts (SimWorld::Impl). The world owns one of each and is
// the only one that sees them all: the targets' and the building's bodies, the robot's bodies,
// the people, the faults and the referee. What crosses parts (the bumper meets people, a fault
// moves a target and the scene is rebuilt, the colour camera lights people) is here.
#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <vector>

#include "bodies/robot_body.hpp"
#include "bodies/targets.hpp"
#include "bodies/world_bodies.hpp"
#include "faults/sim_faults.hpp"
#include "people/crowd.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/host/world.hpp"
#include "projtour_sim/sim_world.hpp"
#include "referee/referee.hpp"

namespace projtour::sim {

// The streams the world draws from while it runs (the setup, building and people streams are
// used up while it is made).
struct RunStreams {
  std::mt19937_64 odometry, laser, encoder, depth, faults, colour;
};

struct SimWorld::Impl {
  explicit Impl(const RunContext& run_context);

  const RunContext* run = nullptr;
  const MissionSpec* mission = nullptr;
  host::WorldSpec world;
  std::uint64_t seed = 1;
  RunStreams rng;

  TrueTargets targets;
  WorldBodies bodies;
  std::unique_ptr<Crowd> crowd;
  SimFaults faults{world.faults};
  BuildingReferee referee;

  SimBaseBody base;
  SimLaserBody laser;
  SimHeadBody head;
  SimDepthBody depth;
  SimColourBody colour_camera;
  SimProjectorBody projector;

  double t_s = 0.0;
  bool started = false;

  // Setting up (world_setup.cpp), in the order of the draws.
  void set_up_robot(std::mt19937_64& setup);
  void set_up_building(std::mt19937_64& setup, std::mt19937_64& building);
  void add_unmapped_objects(std::mt19937_64& building);
  void set_up_people();
  void set_up_cameras();

  // Crossing parts (sim_world.cpp).
  const std::vector<PersonShape>* people() const { return crowd ? &crowd->shapes() : nullptr; }
  Pose2D true_pose() const { return base.true_pose(); }
  TrueTarget* active() { return targets.active(true_pose()); }
  const TrueTarget* active() const { return const_cast<Impl*>(this)->active(); }
  bool collides(const Pose2D& p) const {
    return bodies.collides(p, base.collision_radius_m, people());
  }
  void step(double dt_s);
  void act_faults();
  void schedule_sensors(double now_s);
  void rebuild_scene();
  std::uint64_t view_version(ViewKey& key, const Eigen::Isometry3d& T_map_camera) const;
  ColourRenderer& colour() const;
  double max_colour_exposure_ms() const;
  Eigen::Isometry3d T_map_base() const;
  Eigen::Isometry3d T_map_camera() const;
  Eigen::Isometry3d T_map_projector() const;
  Eigen::Isometry3d T_map_depth() const;
  void log_projector(bool shown);
  // The referee's pictures (sim_world_truth.cpp).
  cv::Mat colour_panel(const TrueTarget& t,
                       const std::optional<std::array<Eigen::Vector2d, 4>>& observed_px) const;
};

}  // namespace projtour::sim
