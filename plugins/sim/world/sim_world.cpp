// The simulated world: its parts stepped together in mission time, and the drivers' side of it
// (base, laser, head, both cameras and the projector over one shared truth).
#include "projtour_sim/sim_world.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "bodies/body_ids.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/run_files.hpp"
#include "world/random_streams.hpp"
#include "world/world_impl.hpp"

namespace projtour::sim {
namespace {

// People stop short of the robot: their edge no nearer its centre than its radius plus this.
constexpr double kPeopleKeepOffM = 0.15;

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::map<const RunContext*, std::weak_ptr<SimWorld>>& registry() {
  static std::map<const RunContext*, std::weak_ptr<SimWorld>> r;
  return r;
}

const RunContext& with_mission(const RunContext& run) {
  if (run.mission == nullptr) throw std::invalid_argument("simulated world: no mission");
  return run;
}

}  // namespace

// One sub-step of dt_s: the base (and its bumper), the head, the people, the referee's
// clearance.
void SimWorld::Impl::step(double dt_s) {
  base.step(
      dt_s, [this](const Pose2D& p) { return collides(p); }, world, rng.odometry);
  head.step(dt_s, t_s, mission->robot.pan_tilt, world, rng.encoder);
  if (crowd) {
    const Pose2D p = true_pose();
    crowd->step(t_s, dt_s, Eigen::Vector2d(p.x_m, p.y_m), bodies.robot_radius_m + kPeopleKeepOffM);
  }
  const Pose2D p = true_pose();
  referee.clearance(Eigen::Vector2d(p.x_m, p.y_m), bodies.footprints, people(),
                    bodies.robot_radius_m);
}

// The faults that act in time, at the target the robot is at.
void SimWorld::Impl::act_faults() {
  faults.kidnap_if_arrived(
      active(), base, [this](const Pose2D& p) { return collides(p); }, rng.faults);
  // The camera's scene is rebuilt whenever a target moves (a BVH cannot move one object).
  if (faults.nudge_if_due(active(), targets, t_s)) rebuild_scene();
  if (crowd && faults.people_if_due(targets, *crowd, t_s)) {
    for (std::size_t i = 0; colour_camera.renderer && i < crowd->size(); ++i) {
      colour_camera.renderer->set_albedo(kFirstPersonId + static_cast<int>(i), kPersonAlbedo);
    }
  }
}

void SimWorld::Impl::rebuild_scene() {
  SceneBuilder builder = bodies.fixed_parts;
  for (const TrueObject& o : targets.objects) {
    if (!o.missing) builder.add_mesh(*o.mesh, o.T_map_model, o.object_id);
  }
  bodies.scene = builder.build();
  if (crowd) bodies.scene.set_people(crowd->shapes());
  ++bodies.scene_version;
}

// A version for a camera at T_map_camera looking along its optical z: it changes with the scene
// and with the people who may be in its view (coarsely: within 6 m and 80 deg of its axis, which
// holds every camera here, whose half field of view is under 35 deg).
std::uint64_t SimWorld::Impl::view_version(ViewKey& key,
                                           const Eigen::Isometry3d& T_map_camera) const {
  std::vector<PersonShape> seen;
  if (crowd) {
    const Eigen::Isometry3d T_camera_map = T_map_camera.inverse();
    for (const PersonShape& p : crowd->shapes()) {
      const Eigen::Vector3d c =
          T_camera_map * Eigen::Vector3d(p.centre_m.x(), p.centre_m.y(), 0.85);
      const double r = c.norm();
      if (r < 6.0 + p.radius_m && (r < 1.2 || c.z() > r * std::cos(deg_to_rad(80.0)))) {
        seen.push_back(p);
      }
    }
  }
  auto same = [](const PersonShape& a, const PersonShape& b) {
    return a.object_id == b.object_id && a.centre_m == b.centre_m;
  };
  if (key.scene_version != bodies.scene_version || seen.size() != key.seen.size() ||
      !std::equal(seen.begin(), seen.end(), key.seen.begin(), same)) {
    ++key.counter;
    key.scene_version = bodies.scene_version;
    key.seen = std::move(seen);
  }
  return key.counter;
}

ColourRenderer& SimWorld::Impl::colour() const {
  auto& renderer = colour_camera.renderer;
  if (!renderer) {
    renderer = std::make_unique<ColourRenderer>(mission->robot.camera.colour.intrinsics,
                                                mission->robot.projector.intrinsics);
    renderer->set_light(colour_camera.light);
    renderer->set_default_albedo(kTargetAlbedo);  // every target id
    renderer->set_albedo(kFloorId, kFloorAlbedo);
    renderer->set_albedo(kWallId, kWallAlbedo);
    renderer->set_albedo(kObstacleId, kObstacleAlbedo);
    for (std::size_t i = 0; crowd && i < crowd->size(); ++i) {
      renderer->set_albedo(kFirstPersonId + static_cast<int>(i), kPersonAlbedo);
    }
  }
  return *renderer;
}

double SimWorld::Impl::max_colour_exposure_ms() const {
  return 1000.0 / std::max(mission->robot.camera.colour.rate_hz, 1e-9);
}

Eigen::Isometry3d SimWorld::Impl::T_map_base() const {
  return isometry_from_pose2d(true_pose());
}

Eigen::Isometry3d SimWorld::Impl::T_map_camera() const {
  return T_map_base() * head.kinematics->T_base_camera(head.q_true);
}

Eigen::Isometry3d SimWorld::Impl::T_map_projector() const {
  return T_map_base() * head.kinematics->T_base_projector(head.q_true);
}

Eigen::Isometry3d SimWorld::Impl::T_map_depth() const {
  // Capture builds its cloud as p_camera = p_depth + depth_to_color_m (the paper's eq. 2), so
  // the depth optical frame sits at +depth_to_color_m in the camera frame.
  Eigen::Isometry3d T_camera_depth = Eigen::Isometry3d::Identity();
  T_camera_depth.translation() = mission->robot.camera.depth_to_color_m;
  return T_map_camera() * T_camera_depth;
}

void SimWorld::Impl::log_projector(bool shown) {
  const TrueTarget* t = active();
  projector.record(
      ProjectorEvent{t_s, shown, base.moving, head.moving_now, t ? t->spec->id : std::string()});
}

std::shared_ptr<SimWorld> SimWorld::attach(const RunContext& run) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto& slot = registry()[&run];
  if (auto world = slot.lock()) return world;
  auto world = std::make_shared<SimWorld>(run);
  slot = world;
  return world;
}

SimWorld::SimWorld(const RunContext& run) : impl_(std::make_unique<Impl>(with_mission(run))) {}

SimWorld::~SimWorld() = default;

void SimWorld::advance(double t_s) {
  Impl& w = *impl_;
  if (w.started && t_s <= w.t_s) return;
  const double dt_total = w.started ? t_s - w.t_s : 0.0;
  w.started = true;
  // Sub-steps bound how far the base moves between bumper checks (5 cm at 0.5 m/s).
  const int steps = std::max(1, static_cast<int>(std::ceil(dt_total / 0.1)));
  const double dt = dt_total / steps;
  const bool was_lit = !is_blank();
  for (int s = 0; s < steps; ++s) {
    w.t_s += dt;
    if (dt > 0.0) w.step(dt);
    if (was_lit && (w.base.moving || w.head.moving_now)) w.projector.lit_moving_s += dt;
  }
  w.t_s = t_s;
  if (dt_total <= 0.0) {
    w.head.step(0.0, w.t_s, w.mission->robot.pan_tilt, w.world, w.rng.encoder);
    if (w.crowd) {
      const Pose2D p = w.true_pose();
      w.crowd->step(w.t_s, 0.0, Eigen::Vector2d(p.x_m, p.y_m),
                    w.bodies.robot_radius_m + kPeopleKeepOffM);
    }
  }
  w.act_faults();
  if (w.crowd) {
    if (w.crowd->moved()) w.bodies.scene.set_people(w.crowd->shapes());
    if (w.projector.lit && !w.crowd->shapes().empty() && !w.projector.shown.empty()) {
      w.referee.light(dt_total, w.projector.shown, w.T_map_projector(),
                      w.mission->robot.projector.intrinsics, w.bodies.scene, w.crowd->shapes());
    }
  }
  w.schedule_sensors(t_s);
}

// Which sensors have a reading due at t_s: the laser's scan is made now, the cameras' frames
// when grabbed.
void SimWorld::Impl::schedule_sensors(double now_s) {
  const LaserSpec& laser_spec = mission->robot.laser;
  if (now_s + 1e-9 >= laser.next_scan_s) {
    laser.scan = bodies.simulate_scan(laser_spec, t_s, true_pose(), laser.threshold,
                                      world.laser_range_noise_m, people(), rng.laser);
    laser.next_scan_s =
        (laser_spec.rate_hz > 0 ? std::floor(now_s * laser_spec.rate_hz + 1e-6) + 1.0 : 1.0) /
        std::max(laser_spec.rate_hz, 1e-9);
  }
  const CameraSpec& camera = mission->robot.camera;
  if (now_s + 1e-9 >= depth.next_frame_s) {
    depth.frame_due_s = now_s;
    depth.next_frame_s =
        (std::floor(now_s * camera.rate_hz + 1e-6) + 1.0) / std::max(camera.rate_hz, 1e-9);
  }
  const double colour_hz = camera.colour.rate_hz;
  if (now_s + 1e-9 >= colour_camera.next_frame_s) {
    colour_camera.frame_due_s = now_s;
    colour_camera.next_frame_s =
        (std::floor(now_s * colour_hz + 1e-6) + 1.0) / std::max(colour_hz, 1e-9);
  }
}

double SimWorld::time_s() const {
  return impl_->t_s;
}

void SimWorld::set_velocity_time_constant(double tau_s) {
  impl_->base.vehicle.setDelayModelParams(std::max(tau_s, 0.0), 0.0);
}

void SimWorld::command_velocity(double v_mps, double w_radps) {
  const BaseSpec& base = impl_->mission->robot.base;
  const double w_max = deg_to_rad(base.max_turn_rate_dps);
  impl_->base.vehicle.movementCommand(std::clamp(v_mps, -base.max_speed_mps, base.max_speed_mps),
                                      std::clamp(w_radps, -w_max, w_max));
}

Odometry SimWorld::odometry() const {
  const SimBaseBody& b = impl_->base;
  return {impl_->t_s, b.odometry_pose, b.odometry_v, b.odometry_w};
}

bool SimWorld::base_blocked() const {
  return impl_->base.blocked;
}
bool SimWorld::base_moving() const {
  return impl_->base.moving;
}

void SimWorld::set_laser_occupancy_threshold(double threshold) {
  impl_->laser.threshold = static_cast<float>(threshold);
}

void SimWorld::set_max_incidence_deg(double deg) {
  impl_->depth.kinect.max_incidence_deg = deg;
}

void SimWorld::set_projector_log_file(const std::filesystem::path& file) {
  if (file.has_parent_path()) make_run_directory(file.parent_path());
  impl_->projector.jsonl = AppendOnlyFile(file);
}

std::optional<LaserScan> SimWorld::take_scan() {
  auto out = std::move(impl_->laser.scan);
  impl_->laser.scan.reset();
  return out;
}

void SimWorld::set_head_settle_time(double settle_s) {
  impl_->head.settle_s = std::max(settle_s, 0.0);
}

void SimWorld::command_head(const JointAngles& angles) {
  const PanTiltSpec& pt = impl_->mission->robot.pan_tilt;
  impl_->head.q_command.pan_rad =
      std::clamp(angles.pan_rad, deg_to_rad(pt.pan_min_deg), deg_to_rad(pt.pan_max_deg));
  impl_->head.q_command.tilt_rad =
      std::clamp(angles.tilt_rad, deg_to_rad(pt.tilt_min_deg), deg_to_rad(pt.tilt_max_deg));
}

JointAngles SimWorld::measured_head() const {
  return impl_->head.q_measured;
}

bool SimWorld::head_reached() const {
  const Impl& w = *impl_;
  const SimHeadBody& h = w.head;
  const double tol = deg_to_rad(w.mission->robot.pan_tilt.tolerance_deg);
  return std::abs(h.q_measured.pan_rad - h.q_command.pan_rad) <= tol &&
         std::abs(h.q_measured.tilt_rad - h.q_command.tilt_rad) <= tol && !h.moving_now &&
         w.t_s - h.at_rest_since_s >= h.settle_s - 1e-9;
}

bool SimWorld::head_moving() const {
  return impl_->head.moving_now;
}
JointAngles SimWorld::true_head() const {
  return impl_->head.q_true;
}

std::optional<DepthFrame> SimWorld::grab() {
  Impl& w = *impl_;
  TrueTarget* here = w.active();
  if (w.faults.depth_disconnected(here)) {
    throw DriverError("simulated depth camera: device disconnected");
  }
  if (!w.depth.frame_due_s) return std::nullopt;
  const double t_frame = *w.depth.frame_due_s;
  w.depth.frame_due_s.reset();
  const PinholeModel& k = w.mission->robot.camera.intrinsics;
  if (here != nullptr) ++here->frames_here;
  const bool dropped = w.faults.frame_dropped(here, w.rng.faults);
  DepthFrame frame;
  if (dropped) {
    frame.intrinsics = k;
    frame.width = k.width;
    frame.height = k.height;
    frame.depth_mm.assign(static_cast<std::size_t>(k.width) * k.height, 0);
  } else {
    // A still camera in a still scene sees the same ideal image: only the noise is new (the
    // beam guard reads every frame of a dwell).
    SimDepthBody& d = w.depth;
    const Eigen::Isometry3d T_map_depth = w.T_map_depth();
    const std::uint64_t version = w.view_version(d.view, T_map_depth);
    if (!d.ideal_key || d.ideal_key->first != version ||
        !d.ideal_key->second.isApprox(T_map_depth, 0.0)) {
      d.renderer->render(w.bodies.scene, T_map_depth, d.ideal, d.kinect.max_depth_m + 0.2);
      d.ideal_key.emplace(version, T_map_depth);
    }
    frame = apply_kinect_noise(d.ideal, k, d.kinect, w.rng.depth);
  }
  frame.t_s = t_frame;
  frame.sequence = ++w.depth.frame_sequence;
  return frame;
}

void SimWorld::set_colour_light(const ColourLight& light) {
  impl_->colour_camera.light = light;
  if (impl_->colour_camera.renderer) impl_->colour_camera.renderer->set_light(light);
}

void SimWorld::set_colour_exposure_ms(double exposure_ms) {
  if (!(exposure_ms >= 0.0) || !std::isfinite(exposure_ms)) {
    throw std::invalid_argument(
        "simulated colour camera: exposure must be >= 0 ms (0 = automatic)");
  }
  impl_->colour_camera.exposure_ms = exposure_ms;
}

std::optional<ColourFrame> SimWorld::grab_colour() {
  Impl& w = *impl_;
  SimColourBody& c = w.colour_camera;
  TrueTarget* here = w.active();
  if (w.faults.colour_disconnected(here)) {
    throw DriverError("simulated colour camera: device disconnected");
  }
  if (!c.frame_due_s) return std::nullopt;
  const double t_frame = *c.frame_due_s;
  c.frame_due_s.reset();
  if (here != nullptr) ++here->colour_frames_here;
  ColourRenderer& renderer = w.colour();
  ColourLight light = c.light;
  if (const auto lux = w.faults.daylight_lux(here)) light.room_lux = *lux;
  // set_light drops the kept geometry: only when the light really changes.
  if (light.room_lux != renderer.light().room_lux) renderer.set_light(light);
  renderer.render(w.bodies.scene, w.view_version(c.view, true_T_map_camera()), true_T_map_camera(),
                  true_T_map_projector(), w.projector.lit ? &w.projector.shown : nullptr,
                  c.radiance);
  const double max_ms = w.max_colour_exposure_ms();
  const double exposure_ms = c.exposure_ms > 0.0
                                 ? std::min(c.exposure_ms, max_ms)
                                 : renderer.auto_exposure_ms(c.radiance, 0.1, max_ms);
  ColourFrame frame = renderer.expose(c.radiance, exposure_ms, &w.rng.colour);
  frame.t_s = t_frame;
  frame.sequence = ++c.sequence;
  return frame;
}

void SimWorld::show(const cv::Mat& frame_bgr) {
  Impl& w = *impl_;
  SimProjectorBody& p = w.projector;
  const PinholeModel& k = w.mission->robot.projector.intrinsics;
  if (frame_bgr.cols != k.width || frame_bgr.rows != k.height) {
    throw std::invalid_argument("simulated projector: frame is " + std::to_string(frame_bgr.cols) +
                                "x" + std::to_string(frame_bgr.rows) + ", the projector " +
                                std::to_string(k.width) + "x" + std::to_string(k.height));
  }
  const int type = frame_bgr.type();
  if (type != CV_8UC3 && type != CV_8UC1 && type != CV_8UC4) {
    throw std::invalid_argument(
        "simulated projector: frames are 8-bit BGR (or grey, or BGRA), got OpenCV type " +
        std::to_string(type));
  }
  TrueTarget* here = w.active();
  if (here != nullptr) {
    if (w.faults.projector_failed(here)) throw DriverError("simulated projector: lamp failure");
    ++here->shows_here;
    if (!here->first_shown_s) here->first_shown_s = w.t_s;
  }
  // A copy: the caller may draw the next frame into the same buffer.
  if (type == CV_8UC3) {
    frame_bgr.copyTo(p.shown);
  } else {
    cv::cvtColor(frame_bgr, p.shown, type == CV_8UC1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  }
  if (here != nullptr) {
    const auto index = static_cast<std::size_t>(here - w.targets.targets.data());
    if (p.last_lit && *p.last_lit != index)
      w.targets.pack_last_frame(w.targets.targets[*p.last_lit]);
    p.last_lit = index;
    p.shown.copyTo(here->last_frame);
    here->last_frame_png.clear();
    here->T_map_camera_shown = true_T_map_camera();
    here->T_map_projector_shown = true_T_map_projector();
    here->last_shown_s = w.t_s;
  }
  p.lit = true;
  w.log_projector(true);
}

void SimWorld::blank() {
  impl_->projector.lit = false;
  impl_->log_projector(false);
}

bool SimWorld::is_blank() const {
  return !impl_->projector.lit;
}
const std::vector<ProjectorEvent>& SimWorld::projector_log() const {
  return impl_->projector.log;
}
double SimWorld::lit_while_moving_s() const {
  return impl_->projector.lit_moving_s;
}

std::string SimWorld::active_target() const {
  const TrueTarget* t = impl_->active();
  return t ? t->spec->id : std::string();
}

void SimWorld::set_true_base_pose(const Pose2D& pose) {
  impl_->base.vehicle.setCurrentGTPose(mrpt::math::TPose2D(pose.x_m, pose.y_m, pose.yaw_rad));
}

}  // namespace projtour::sim
