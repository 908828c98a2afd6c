#pragma once
// A small in-process dry run for the navigation tests: a differential-drive base with noisy
// odometry and a simulated laser on a (possibly changed) copy of the map, the localization
// service and one behaviour from the built plugins, stepped on a fixed clock.
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/navigation/path_planner.hpp"
#include "projtour_test/run_rig.hpp"

namespace projtour::nav_test {

// The truth of the simulated world.
struct World {
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;  // what the laser sees
  std::unique_ptr<navigation::InflatedGrid> bumper;      // where the base can be
  Pose2D truth;
  std::mt19937 random;
  double odometry_noise_frac = 0.03;
  void rebuild_bumper();
  // Draws a box of occupied cells into the world (the robot's map does not have it).
  void add_box(double x0_m, double y0_m, double x1_m, double y1_m);
};

class SimBase : public BaseDriver {
 public:
  explicit SimBase(World& world) : world_(world) { odometry_.pose = world.truth; }
  void update(double t_s) override;
  void safe_stop() override { command_velocity(0, 0); }
  void command_velocity(double v_mps, double w_radps) override;
  Odometry odometry() const override { return odometry_; }

 private:
  World& world_;
  Odometry odometry_;
  double last_t_s_ = 0.0;
};

class SimLaser : public LaserDriver {
 public:
  explicit SimLaser(World& world) : world_(world) {}
  void update(double t_s) override;
  void safe_stop() override {}
  std::optional<LaserScan> take_scan() override;

 private:
  World& world_;
  std::optional<LaserScan> newest_;
  double next_scan_s_ = 0.0;
};

// Where the base and laser come from: this file's small simulator (whose world a test can
// change), or the project's `sim` plugin (sim_base, sim_laser), loaded like in a dry run.
enum class Drivers { harness, sim_plugin };

class Rig {
 public:
  // `map_file` is what the robot believes; the world starts as the same map.
  // `tune_localization` changes the localization service's parameters before it starts.
  Rig(const std::string& map_file, const Pose2D& start, std::uint64_t seed,
      Drivers drivers = Drivers::harness,
      const std::function<void(Params&)>& tune_localization = {});
  ~Rig();

  // The harness's world (Drivers::harness only).
  World& world() { return world_; }
  // The true base pose, from whichever simulator runs.
  Pose2D truth() const;
  Blackboard& blackboard() { return board_; }
  const host::PluginRegistry& registry() const { return registry_; }
  double now_s() const { return clock_.now_s(); }
  const MissionSpec& mission() const { return mission_; }
  const mrpt::maps::COccupancyGridMap2D& map() const { return *map_; }

  // Default parameters of a kind, for overriding.
  Params defaults(const std::string& kind) const;
  // One executor step: clock, drivers, localization.
  void step();
  // Runs a behaviour from start to its outcome (or until max_s, then nullopt).
  std::optional<Outcome> run(const std::string& kind, const Params& params,
                             const TargetSpec* target, double max_s);
  // Steps with the base at rest.
  void idle(double duration_s);
  PoseEstimate2D estimate() const;

  static constexpr double kTickS = 0.05;

 private:
  Context context(const Params* params, const TargetSpec* target);

  // First in, last out: blackboard values a plugin stored keep pointers into its library
  // (std::any's manager), so the libraries outlive everything else.
  host::PluginRegistry registry_;
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map_;
  World world_;
  test::RunRig rig_;
  MissionSpec& mission_ = rig_.mission;
  DriverSet& drivers_ = rig_.drivers;
  Blackboard& board_ = rig_.blackboard;
  SteppedClock& clock_ = rig_.clock;
  RunContext& run_ = rig_.run;
  Params localization_params_;
  std::shared_ptr<Service> localization_;
};

// A target whose stand-off pose (1 m in front) is `goal`.
TargetSpec target_for_goal(const std::string& id, const Pose2D& goal);

double distance_m(const Pose2D& a, const Pose2D& b);
double heading_error_rad(const Pose2D& a, const Pose2D& b);

}  // namespace projtour::nav_test
