// Making the world: its parts set up in the order of the draws every run makes (the setup
// stream's odometry bias, calibration error, target offsets and surfaces; the building stream's
// clutter; the people stream's seed). Reordering them changes every dry run.
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "bodies/body_ids.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "world/random_streams.hpp"
#include "world/world_impl.hpp"

namespace projtour::sim {

SimWorld::Impl::Impl(const RunContext& run_context)
    : run(&run_context),
      mission(run_context.mission),
      world(run_context.world ? *run_context.world : host::WorldSpec{}),
      seed(run_context.seed) {
  std::mt19937_64 setup = stream(seed, Stream::setup);
  rng.odometry = stream(seed, Stream::odometry);
  rng.laser = stream(seed, Stream::laser);
  rng.encoder = stream(seed, Stream::encoder);
  rng.depth = stream(seed, Stream::depth);
  rng.faults = stream(seed, Stream::faults);
  rng.colour = stream(seed, Stream::colour);
  set_up_robot(setup);
  bodies.robot_radius_m = mission->robot.base.radius_m;
  std::mt19937_64 building = stream(seed, Stream::building);
  set_up_building(setup, building);
  set_up_people();
  rebuild_scene();
  set_up_cameras();

  // Base: MRPT's simulator for the true motion; it starts where the mission says.
  base.vehicle.setOdometryErrors(false);
  base.vehicle.setDelayModelParams(0.1, 0.0);
  base.vehicle.setCurrentGTPose(
      mrpt::math::TPose2D(mission->start.x_m, mission->start.y_m, mission->start.yaw_rad));
  base.odometry_pose = mission->start;

  const PanTiltSpec& pt = mission->robot.pan_tilt;
  head.q_true = {deg_to_rad(pt.stow_pan_deg), deg_to_rad(pt.stow_tilt_deg)};
  head.q_command = head.q_true;
  head.q_measured = head.q_true;
}

void SimWorld::Impl::set_up_robot(std::mt19937_64& setup) {
  const RobotSpec& robot = mission->robot;
  // Odometry: a per-run scale error between half and all of the configured fraction.
  base.odometry_trans_bias = world.odometry_trans_noise_frac * uniform(setup, 0.5, 1.0) *
                             (uniform(setup, 0, 1) < 0.5 ? -1.0 : 1.0);
  base.odometry_rot_bias = world.odometry_rot_noise_frac * uniform(setup, 0.5, 1.0) *
                           (uniform(setup, 0, 1) < 0.5 ? -1.0 : 1.0);

  // Calibration: the true projector mount is the robot file's moved by exactly the configured
  // error, in a seeded direction about a seeded axis.
  MountSpec projector_true = robot.projector.mount;
  Eigen::Isometry3d calib = Eigen::Isometry3d::Identity();
  calib.translation() = random_unit(setup) * (world.calibration_error_mm * 1e-3);
  calib.linear() = Eigen::AngleAxisd(deg_to_rad(world.calibration_error_deg), random_unit(setup))
                       .toRotationMatrix();
  projector_true.T_link_body = projector_true.T_link_body * calib;
  head.kinematics =
      std::make_unique<head::HeadKinematics>(robot.pan_tilt, robot.camera.mount, projector_true);
}

void SimWorld::Impl::set_up_building(std::mt19937_64& setup, std::mt19937_64& building) {
  if (run->map) {
    bodies.grid = building_walls(*run->map, world.map_error,
                                 Eigen::Vector2d(mission->start.x_m, mission->start.y_m));
  }
  // Glass: the building's walls the laser and the cameras see through (the bumper does not).
  auto without_glass = [&]() {
    auto seen = std::make_shared<mrpt::maps::COccupancyGridMap2D>(*bodies.grid);
    for (const host::WallSegmentSpec& g : world.glass) paint_segment(*seen, g, 1.0f);
    return seen;
  };
  for (std::size_t i = 0; i < world.glass.size(); ++i) {
    bodies.glass.push_back(glass_footprint(world.glass[i], "glass " + std::to_string(i)));
  }
  SceneBuilder& builder = bodies.fixed_parts;
  builder.set_floor(0.0, kFloorId);
  if (bodies.grid) {
    builder.add_occupancy_walls(bodies.glass.empty() ? *bodies.grid : *without_glass(), 2.0,
                                kWallId);
  }
  // Targets: true poses and true surfaces; then the static faults, which stand before them.
  targets.build(*mission, world, setup, [this](const std::string& id) { return faults.flags(id); });
  faults.place(targets, bodies);
  add_unmapped_objects(building);
  // The laser's walls: with the static faults painted in, without the glass.
  if (bodies.grid && !bodies.glass.empty()) bodies.laser_grid = without_glass();
}

// The unmapped objects: listed, supports under the targets, clutter along the walls.
void SimWorld::Impl::add_unmapped_objects(std::mt19937_64& building) {
  std::vector<std::pair<host::WorldObjectSpec, std::string>> unmapped;
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    unmapped.emplace_back(world.objects[i], "object " + std::to_string(i));
  }
  if (world.supports) {
    for (const TrueObject& o : targets.objects) {
      if (o.missing) continue;
      std::string name = "support of " + o.model_key;
      for (const TrueTarget& t : targets.targets) {
        if (t.object == static_cast<std::size_t>(&o - targets.objects.data())) {
          name = "support of " + t.spec->id;
          break;
        }
      }
      for (const host::WorldObjectSpec& s : target_supports(*o.mesh, o.T_map_model)) {
        unmapped.emplace_back(s, name);
      }
    }
  }
  std::vector<Eigen::Vector2d> tour_places{{mission->start.x_m, mission->start.y_m}};
  for (const TrueTarget& t : targets.targets) {
    tour_places.emplace_back(t.standoff.x_m, t.standoff.y_m);
    tour_places.push_back(targets.object(t).T_map_model.translation().head<2>());
  }
  if (bodies.grid) {
    const auto clutter =
        place_clutter(*bodies.grid, world.clutter, tour_places, bodies.robot_radius_m, building);
    for (std::size_t i = 0; i < clutter.size(); ++i) {
      unmapped.emplace_back(clutter[i], "clutter " + std::to_string(i));
    }
  }
  for (const auto& [object, name] : unmapped) {
    bodies.footprints.push_back(object_footprint(object, name));
    add_object(bodies.fixed_parts, object, kObstacleId);
  }
}

void SimWorld::Impl::set_up_people() {
  if (world.people.walkers <= 0 && world.people.list.empty() && !faults.any_person_faults()) {
    return;
  }
  std::vector<Footprint> blocking = bodies.footprints;
  blocking.insert(blocking.end(), bodies.glass.begin(), bodies.glass.end());
  // Nobody walks through a target either (the beam guard could not tell them from it).
  for (const TrueObject& o : targets.objects) {
    if (o.missing) continue;
    if (auto f = target_footprint(*o.mesh, o.T_map_model, "target " + o.model_key)) {
      blocking.push_back(*f);
    }
  }
  std::vector<Eigen::Vector2d> homes;
  for (const TrueTarget& t : targets.targets) homes.emplace_back(t.standoff.x_m, t.standoff.y_m);
  std::mt19937_64 people_stream = stream(seed, Stream::people);
  crowd = std::make_unique<Crowd>(world.people, bodies.grid.get(), blocking, homes, kFirstPersonId,
                                  people_stream());
}

void SimWorld::Impl::set_up_cameras() {
  const RobotSpec& robot = mission->robot;
  depth.renderer = std::make_unique<DepthRenderer>(robot.camera.intrinsics);
  KinectNoiseParams& kinect = depth.kinect;
  kinect.axial_noise = world.depth_noise;
  if (world.depth_artefacts) {
    kinect.shadows = true;
    kinect.flying_pixels = true;
    kinect.correlated_noise = world.depth_noise;
    // The Kinect's 9 px matching window is at 640 px across.
    kinect.correlation_window_px =
        std::max(1, static_cast<int>(std::lround(9.0 * robot.camera.intrinsics.width / 640.0)));
  }
  kinect.min_depth_m = robot.camera.min_range_m;
  kinect.max_depth_m = robot.camera.max_range_m;
}

}  // namespace projtour::sim
