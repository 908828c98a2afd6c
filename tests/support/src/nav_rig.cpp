#include "projtour_test/nav_rig.hpp"

#include <mrpt/obs/CObservation2DRangeScan.h>

#include <cmath>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/navigation/localizer.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace projtour::nav_test {

namespace {
constexpr double kBumperRadiusM = 0.25;
constexpr double kLaserPeriodS = 0.1;
}  // namespace

void World::rebuild_bumper() {
  bumper = std::make_unique<navigation::InflatedGrid>(*map, kBumperRadiusM);
}

void World::add_box(double x0_m, double y0_m, double x1_m, double y1_m) {
  const double step = map->getResolution() * 0.5;
  for (double y = y0_m; y <= y1_m; y += step) {
    for (double x = x0_m; x <= x1_m; x += step) {
      map->setPos(static_cast<float>(x), static_cast<float>(y), 0.0f);
    }
  }
  rebuild_bumper();
}

void SimBase::command_velocity(double v_mps, double w_radps) {
  odometry_.v_mps = v_mps;
  odometry_.w_radps = w_radps;
}

void SimBase::update(double t_s) {
  const double dt_s = t_s - last_t_s_;
  last_t_s_ = t_s;
  odometry_.t_s = t_s;
  if (dt_s <= 0.0) return;
  const Pose2D step{odometry_.v_mps * dt_s, 0.0, odometry_.w_radps * dt_s};
  const Pose2D next = navigation::pose_compose(world_.truth, step);
  // The bumper: the base does not move into walls or boxes.
  if (!world_.bumper->fits({next.x_m, next.y_m})) return;
  world_.truth = next;
  std::normal_distribution<double> noise(0.0, 1.0);
  const double f = world_.odometry_noise_frac;
  const Pose2D measured{step.x_m * (1.0 + f * noise(world_.random)),
                        std::abs(step.x_m) * f * 0.3 * noise(world_.random),
                        step.yaw_rad + (std::abs(step.yaw_rad) + 0.2 * std::abs(step.x_m)) * f *
                                           noise(world_.random)};
  odometry_.pose = navigation::pose_compose(odometry_.pose, measured);
}

void SimLaser::update(double t_s) {
  if (t_s + 1e-9 < next_scan_s_) return;
  next_scan_s_ = t_s + kLaserPeriodS;
  mrpt::obs::CObservation2DRangeScan obs;
  obs.aperture = static_cast<float>(deg_to_rad(270.0));
  obs.maxRange = 20.0f;
  obs.rightToLeft = true;
  obs.sensorPose = mrpt::poses::CPose3D(0.2, 0.0, 0.3, 0.0, 0.0, 0.0);
  constexpr int kRays = 541;
  world_.map->laserScanSimulator(
      obs, mrpt::poses::CPose2D(world_.truth.x_m, world_.truth.y_m, world_.truth.yaw_rad), 0.6f,
      kRays, 0.01f);
  LaserScan scan;
  scan.t_s = t_s;
  scan.angle_min_rad = -0.5 * obs.aperture;
  scan.angle_increment_rad = obs.aperture / (kRays - 1);
  scan.max_range_m = obs.maxRange;
  scan.T_base_laser = Eigen::Isometry3d::Identity();
  scan.T_base_laser.translation() = Eigen::Vector3d(0.2, 0.0, 0.3);
  for (int i = 0; i < kRays; ++i) {
    scan.ranges_m.push_back(obs.getScanRange(i));
    scan.valid.push_back(obs.getScanRangeValidity(i) ? 1 : 0);
  }
  newest_ = std::move(scan);
}

std::optional<LaserScan> SimLaser::take_scan() {
  auto out = std::move(newest_);
  newest_.reset();
  return out;
}

Rig::Rig(const std::string& map_file, const Pose2D& start, std::uint64_t seed, Drivers drivers,
         const std::function<void(Params&)>& tune_localization)
    : map_(navigation::load_occupancy_grid(map_file)) {
  world_.map = std::make_shared<mrpt::maps::COccupancyGridMap2D>(*map_);
  world_.rebuild_bumper();
  world_.truth = start;
  world_.random.seed(static_cast<std::mt19937::result_type>(seed));
  mission_.name = "nav-test";
  mission_.start = start;
  rig_.log.set_echo(LogLevel::warning);
  run_.seed = seed;
  run_.map = map_;
  registry_.load_library(PROJTOUR_PLUGIN_BUILD_DIR "/libprojtour_localization.so");
  registry_.load_library(PROJTOUR_PLUGIN_BUILD_DIR "/libprojtour_navigate.so");
  if (drivers == Drivers::harness) {
    drivers_.base = std::make_shared<SimBase>(world_);
    drivers_.laser = std::make_shared<SimLaser>(world_);
  } else {
    // The simulator needs the whole robot (camera intrinsics, laser spec): the example's.
    host::Diagnostics diag;
    const auto robot = host::load_robot(PROJTOUR_SOURCE_DIR "/examples/robot/ud.yaml", diag);
    if (!robot) throw host::InputError(diag);
    mission_.robot = *robot;
    registry_.load_library(PROJTOUR_PLUGIN_BUILD_DIR "/libprojtour_sim.so");
    drivers_.base = std::dynamic_pointer_cast<BaseDriver>(
        registry_.create_driver("sim_base", defaults("sim_base"), run_));
    drivers_.laser = std::dynamic_pointer_cast<LaserDriver>(
        registry_.create_driver("sim_laser", defaults("sim_laser"), run_));
  }
  localization_params_ = defaults("mrpt_localization");
  if (tune_localization) tune_localization(localization_params_);
  localization_ = registry_.create_service("mrpt_localization", localization_params_, run_);
  for (const auto& d : drivers_.all()) d->update(0.0);
  Context ctx = context(&localization_params_, nullptr);
  localization_->start(ctx);
}

Rig::~Rig() {
  Context ctx = context(&localization_params_, nullptr);
  localization_->stop(ctx);
}

Params Rig::defaults(const std::string& kind) const {
  return host::default_params(registry_.require(kind).params);
}

Context Rig::context(const Params* params, const TargetSpec* target) {
  Context ctx = rig_.context(params);
  ctx.target = target;
  return ctx;
}

void Rig::step() {
  clock_.advance(kTickS);
  for (const auto& d : drivers_.all()) d->update(clock_.now_s());
  Context ctx = context(&localization_params_, nullptr);
  localization_->update(ctx);
}

std::optional<Outcome> Rig::run(const std::string& kind, const Params& params,
                                const TargetSpec* target, double max_s) {
  auto behaviour = registry_.create_behaviour(kind, params, run_);
  Context ctx = context(&params, target);
  behaviour->start(ctx);
  const double end_s = clock_.now_s() + max_s;
  std::optional<Outcome> outcome;
  while (!outcome && clock_.now_s() < end_s) {
    step();
    outcome = behaviour->tick(ctx);
  }
  behaviour->stop(ctx);
  return outcome;
}

void Rig::idle(double duration_s) {
  drivers_.base->command_velocity(0, 0);
  const double end_s = clock_.now_s() + duration_s;
  while (clock_.now_s() < end_s) step();
}

Pose2D Rig::truth() const {
  if (const GroundTruth* truth = drivers_.ground_truth()) {
    return pose2d_from_isometry(truth->true_T_map_base());
  }
  return world_.truth;
}

PoseEstimate2D Rig::estimate() const {
  const PoseEstimate2D* estimate = board_.find(keys::kLocalization);
  if (estimate == nullptr) throw std::runtime_error("no localization estimate on the blackboard");
  return *estimate;
}

TargetSpec target_for_goal(const std::string& id, const Pose2D& goal) {
  TargetSpec t;
  t.id = id;
  t.standoff_m = 1.0;
  const double x = goal.x_m + std::cos(goal.yaw_rad), y = goal.y_m + std::sin(goal.yaw_rad);
  t.T_map_model = isometry_from_xyz_rpy(x, y, 1.0, 0.0, 0.0, goal.yaw_rad + kPi);
  return t;
}

double distance_m(const Pose2D& a, const Pose2D& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

double heading_error_rad(const Pose2D& a, const Pose2D& b) {
  return std::abs(wrap_angle_rad(a.yaw_rad - b.yaw_rad));
}

}  // namespace projtour::nav_test
