// The simulated world: base, laser, head, camera and projector over one shared truth.
#include "projtour_sim/sim_world.hpp"

#include <mrpt/kinematics/CVehicleSimul_DiffDriven.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "building.hpp"
#include "projtour/geometry.hpp"
#include "projtour/kinematics.hpp"
#include "projtour/model.hpp"
#include "projtour/occupancy_map.hpp"
#include "projtour/run_files.hpp"
#include "projtour_sim/colour_renderer.hpp"
#include "projtour_sim/depth_renderer.hpp"
#include "projtour_sim/kinect_noise.hpp"
#include "sim_internal.hpp"

namespace projtour::sim {
namespace {

// Object ids in the rendered scene.
constexpr int kFloorId = 0;
constexpr int kWallId = 1;
constexpr int kObstacleId = 2;
constexpr int kFirstTargetId = 10;
// People after every target (a long day's tour has hundreds of objects).
constexpr int kFirstPersonId = 1000000;
// What counts as lit in a projector frame: above the black level of a blanked pixel.
constexpr int kLitLevel = 8;
// The referee's clearance: the robot's radius plus this to any object or person.
constexpr double kClearanceMarginM = 0.10;
// People stop short of the robot: their edge no nearer its centre than its radius plus this.
constexpr double kPeopleKeepOffM = 0.15;

// Independent random streams, so e.g. grabbing one more frame does not change the laser noise.
// New streams go at the end: the others' seeds, and so every existing run, stay as they were.
enum class Stream : std::uint64_t {
  setup = 1,
  odometry,
  laser,
  encoder,
  depth,
  faults,
  colour,
  building,
  people
};

// What the colour camera sees each kind of object as (linear B, G, R reflectance): white-ish
// targets that take the content well, mid-grey walls and obstacles, a dark brownish floor.
constexpr Albedo kTargetAlbedo{0.8f, 0.8f, 0.8f};
constexpr Albedo kWallAlbedo{0.5f, 0.5f, 0.5f};
constexpr Albedo kObstacleAlbedo{0.4f, 0.42f, 0.45f};
constexpr Albedo kFloorAlbedo{0.14f, 0.18f, 0.22f};
constexpr Albedo kPersonAlbedo{0.25f, 0.3f, 0.35f};

// The pole fault's shape: a 16-sided prism is round to within 2 % of its diameter.
constexpr int kPoleSides = 16;
constexpr double kPoleHeight_m = 2.0;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::mt19937_64 stream(std::uint64_t seed, Stream s) {
  return std::mt19937_64(splitmix64(seed * 0x100000001B3ull + static_cast<std::uint64_t>(s)));
}

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

double gaussian(std::mt19937_64& rng) {
  // Box-Muller on the raw engine output: reproducible across standard libraries.
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

Eigen::Vector3d random_unit(std::mt19937_64& rng) {
  const double z = uniform(rng, -1.0, 1.0), phi = uniform(rng, 0.0, 2.0 * kPi);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

double fault_value(const FaultSpec& f, const std::string& key, double fallback) {
  const auto it = f.values.find(key);
  return it == f.values.end() ? fallback : it->second;
}

mrpt::poses::CPose3D to_cpose3d(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d ypr = T.linear().eulerAngles(2, 1, 0);
  const Eigen::Vector3d t = T.translation();
  return mrpt::poses::CPose3D(t.x(), t.y(), t.z(), ypr[0], ypr[1], ypr[2]);
}

// The true surface differs from the robot's model by a smooth field of about `rms_m` along the
// vertex normals: a sum of random plane waves of 4 to 15 cm wavelength, as a Kinect Fusion scan
// differs from the object it was made of.
TriangleMesh perturbed_mesh(const TriangleMesh& mesh, double rms_m, std::mt19937_64& rng) {
  if (rms_m <= 0.0) return mesh;
  std::vector<Eigen::Vector3f> normals(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3i& f : mesh.triangles) {
    const Eigen::Vector3f n = (mesh.vertices[f[1]] - mesh.vertices[f[0]])
                                  .cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    for (int k = 0; k < 3; ++k) normals[f[k]] += n;  // area-weighted
  }
  constexpr int kWaves = 12;
  std::array<Eigen::Vector3d, kWaves> k_vec;
  std::array<double, kWaves> phase;
  for (int w = 0; w < kWaves; ++w) {
    k_vec[w] = random_unit(rng) * (2.0 * kPi / uniform(rng, 0.04, 0.15));
    phase[w] = uniform(rng, 0.0, 2.0 * kPi);
  }
  std::vector<double> field(mesh.vertices.size());
  double sum2 = 0.0;
  for (std::size_t i = 0; i < field.size(); ++i) {
    double f = 0.0;
    for (int w = 0; w < kWaves; ++w)
      f += std::sin(k_vec[w].dot(mesh.vertices[i].cast<double>()) + phase[w]);
    field[i] = f;
    sum2 += f * f;
  }
  const double scale = sum2 > 0.0 ? rms_m / std::sqrt(sum2 / field.size()) : 0.0;
  TriangleMesh out = mesh;
  for (std::size_t i = 0; i < field.size(); ++i) {
    const float len = normals[i].norm();
    if (len > 0.0f) out.vertices[i] += static_cast<float>(field[i] * scale) * (normals[i] / len);
  }
  return out;
}

}  // namespace

struct SimWorld::Impl {
  // One physical object. Targets naming the same model at the same true pose are one object
  // visited again (a long day's tour goes back and forth): it is perturbed and rendered once,
  // so the world's size follows the objects in the building, not the visits in the mission.
  struct Object {
    std::shared_ptr<const TriangleMesh> mesh;  // model frame, the true (perturbed) surface
    Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
    int object_id = 0;
    std::string model_key;
    bool missing = false;
    bool shared = false;  // other targets may stand on it: no fault moves or removes it
  };
  struct Target {
    const TargetSpec* spec = nullptr;
    std::size_t object = 0;  // index into objects
    Pose2D standoff;
    int frames_here = 0;
    int shows_here = 0;
    bool kidnapped = false;
    std::optional<double> first_shown_s;  // the projector first lit while this target was active
    bool nudged = false;
    int colour_frames_here = 0;
    // The last frame shown while this target was active, for the referee's pictures. Only the
    // target lit last keeps it raw; the others' are PNG-packed (a long day has hundreds).
    cv::Mat last_frame;
    std::vector<std::uint8_t> last_frame_png;
    Eigen::Isometry3d T_map_camera_shown = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_map_projector_shown = Eigen::Isometry3d::Identity();
    std::optional<double> last_shown_s;
  };
  struct Box2 {
    Eigen::Vector2d lo, hi;
  };

  const RunContext* run = nullptr;
  const MissionSpec* mission = nullptr;
  WorldSpec world;
  std::uint64_t seed = 1;
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> grid;  // the map plus added obstacles

  std::vector<Object> objects;
  std::vector<Target> targets;
  std::optional<std::size_t> visited;  // index into targets, from set_visited_target
  // The referee's scene of one object alone, built when a truth query needs it: only the
  // object being projected on is ever asked about, so one is kept.
  mutable std::optional<std::pair<std::size_t, Scene>> alone_cache;
  std::vector<Box2> obstacles;  // blocked_path boxes and poles, for the bumper
  // The building (building.hpp). `grid` holds its walls, glass included (the bumper's);
  // `laser_grid` the same without the glass (what the laser and the cameras see).
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> laser_grid;
  std::vector<Footprint> footprints;  // unmapped objects: laser, bumper, referee
  std::vector<Footprint> glass;       // the bumper's only
  std::unique_ptr<Crowd> crowd;
  double robot_radius_m = 0.35;
  struct PersonFault {
    std::size_t target = 0;
    const FaultSpec* fault = nullptr;
    bool done = false;
  };
  std::vector<PersonFault> person_faults;
  // The referee's figures of the building (see sim_world.hpp).
  // Clearance and light; building_truth() adds the counts.
  BuildingTruth figures;  // min_clearance_m starts at infinity (the constructor)
  bool in_violation = false;
  SceneBuilder fixed_parts;  // floor, walls and obstacles: all the scene but the targets
  Scene scene;
  std::uint64_t scene_version = 0;  // counts rebuilds: the colour camera keeps geometry per scene
  // What the cameras' caches are keyed by: the scene's rebuilds and the people they could see
  // (people walking elsewhere leave a camera's image as it was).
  struct ViewKey {
    std::uint64_t counter = 0;
    std::uint64_t scene_version = ~0ull;
    std::vector<PersonShape> seen;
  };
  ViewKey depth_view, colour_view;
  std::unique_ptr<DepthRenderer> depth_renderer;
  KinectNoiseParams kinect;
  std::unique_ptr<HeadKinematics> head_true;

  std::mt19937_64 rng_odometry, rng_laser, rng_encoder, rng_depth, rng_faults, rng_colour;

  double t_s = 0.0;
  bool started = false;

  // Base.
  mrpt::kinematics::CVehicleSimul_DiffDriven vehicle;
  double collision_radius_m = 0.15;
  Pose2D odometry_pose;
  double odometry_v = 0.0, odometry_w = 0.0;
  double odometry_trans_bias = 0.0, odometry_rot_bias = 0.0;
  bool blocked = false;
  bool moving = false;

  // Laser.
  float laser_threshold = 0.6f;
  double next_scan_s = 0.0;
  std::optional<LaserScan> scan;

  // Head.
  JointAngles q_true, q_command, q_measured;
  double settle_s = 0.1;
  double at_rest_since_s = -1e9;  // at rest since before the mission
  bool head_moving_now = false;

  // Camera.
  double next_frame_s = 0.0;
  std::optional<double> frame_due_s;
  std::uint64_t frame_sequence = 0;
  IdealDepth ideal;
  std::optional<std::pair<std::uint64_t, Eigen::Isometry3d>> ideal_key;  // what `ideal` shows

  // Colour camera. Its renderer is made on first use: most runs never grab a colour frame.
  double next_colour_frame_s = 0.0;
  std::optional<double> colour_frame_due_s;
  std::uint64_t colour_sequence = 0;
  double colour_exposure_ms = 0.0;  // 0 = automatic
  ColourLight colour_light;
  mutable std::unique_ptr<ColourRenderer> colour_renderer;
  cv::Mat colour_radiance;

  // Projector.
  bool lit = false;
  cv::Mat shown;                        // 8-bit BGR: what the projector shows while lit
  std::optional<std::size_t> last_lit;  // the target whose last_frame is raw
  std::vector<ProjectorEvent> projector_log;
  double lit_moving_s = 0.0;
  AppendOnlyFile projector_jsonl;  // appended on resume, like events.jsonl

  Target* target(const std::string& id) {
    for (auto& t : targets) {
      if (t.spec->id == id) return &t;
    }
    return nullptr;
  }
  const Target* target(const std::string& id) const { return const_cast<Impl*>(this)->target(id); }

  Object& object(const Target& t) { return objects[t.object]; }
  const Object& object(const Target& t) const { return objects[t.object]; }

  const Scene& alone(const Target& t) const {
    if (!alone_cache || alone_cache->first != t.object) {
      const Object& o = object(t);
      SceneBuilder builder;
      builder.add_mesh(*o.mesh, o.T_map_model, o.object_id);
      alone_cache.emplace(t.object, builder.build());
    }
    return alone_cache->second;
  }

  const FaultSpec* fault(const std::string& target_id, const std::string& type) const {
    for (const auto& f : world.faults) {
      if (f.target == target_id && f.type == type) return &f;
    }
    return nullptr;
  }

  Pose2D true_pose() const {
    const auto& p = vehicle.getCurrentGTPose();
    return {p.x, p.y, p.phi};
  }

  // The target the robot is at: the nearest within reach of its stand-off pose. Targets at one
  // place (an object visited again) are equally near; the visit under way is the one meant.
  Target* active() {
    const Pose2D p = true_pose();
    Target* best = nullptr;
    double best_d = 0.0;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      Target& t = targets[i];
      const Eigen::Vector3d c = object(t).T_map_model.translation();
      const double d = std::hypot(c.x() - p.x_m, c.y() - p.y_m);
      if (d > t.spec->standoff_m + 1.5) continue;
      if (best == nullptr || d < best_d || (d == best_d && visited == i)) {
        best = &t;
        best_d = d;
      }
    }
    return best;
  }

  bool collides(const Pose2D& p) const {
    const Eigen::Vector2d xy(p.x_m, p.y_m);
    for (const auto* list : {&footprints, &glass}) {
      for (const Footprint& f : *list) {
        if (f.distance_m(xy) < robot_radius_m) return true;
      }
    }
    if (crowd) {
      for (const PersonShape& s : crowd->shapes()) {
        if ((s.centre_m.cast<double>() - xy).norm() < robot_radius_m + s.radius_m) return true;
      }
    }
    for (const auto& b : obstacles) {
      const Eigen::Vector2d c(std::clamp(p.x_m, b.lo.x(), b.hi.x()),
                              std::clamp(p.y_m, b.lo.y(), b.hi.y()));
      if ((c - Eigen::Vector2d(p.x_m, p.y_m)).norm() < collision_radius_m) return true;
    }
    if (!grid) return false;
    const double res = grid->getResolution();
    const int reach = static_cast<int>(std::ceil(collision_radius_m / res));
    const int cx = grid->x2idx(p.x_m), cy = grid->y2idx(p.y_m);
    for (int j = cy - reach; j <= cy + reach; ++j) {
      for (int i = cx - reach; i <= cx + reach; ++i) {
        if (i < 0 || j < 0 || i >= static_cast<int>(grid->getSizeX()) ||
            j >= static_cast<int>(grid->getSizeY())) {
          continue;  // off the map counts as unknown, not as a wall
        }
        if (grid->getCell(i, j) >= 0.5f) continue;
        if (std::hypot(grid->idx2x(i) - p.x_m, grid->idx2y(j) - p.y_m) <=
            collision_radius_m + 0.5 * res) {
          return true;
        }
      }
    }
    return false;
  }

  void step_base(double dt_s) {
    const Pose2D before = true_pose();
    vehicle.simulateOneTimeStep(dt_s);
    Pose2D after = true_pose();
    if (collides(after) && !collides(before)) {
      // The bumper: the base stops where it was; pushing on keeps it there.
      vehicle.setCurrentGTPose(mrpt::math::TPose2D(before.x_m, before.y_m, before.yaw_rad));
      vehicle.movementCommand(0.0, 0.0);
      vehicle.setV(0.0);
      vehicle.setW(0.0);
      blocked = true;
      after = before;
    } else if (std::hypot(after.x_m - before.x_m, after.y_m - before.y_m) > 1e-9) {
      blocked = false;  // moved freely again
    }
    // Odometry integrates the true local increment with a per-run scale bias and white noise.
    const mrpt::poses::CPose2D delta = mrpt::poses::CPose2D(after.x_m, after.y_m, after.yaw_rad) -
                                       mrpt::poses::CPose2D(before.x_m, before.y_m, before.yaw_rad);
    const double trans_noise = world.odometry_trans_noise_frac * 0.3 * gaussian(rng_odometry);
    const double rot_noise = world.odometry_rot_noise_frac * 0.3 * gaussian(rng_odometry);
    const double ts = 1.0 + odometry_trans_bias + trans_noise;
    const double rs = 1.0 + odometry_rot_bias + rot_noise;
    const mrpt::poses::CPose2D measured(delta.x() * ts, delta.y() * ts, delta.phi() * rs);
    const mrpt::poses::CPose2D odo =
        mrpt::poses::CPose2D(odometry_pose.x_m, odometry_pose.y_m, odometry_pose.yaw_rad) +
        measured;
    odometry_pose = {odo.x(), odo.y(), odo.phi()};
    odometry_v = dt_s > 0 ? delta.x() * ts / dt_s : 0.0;
    odometry_w = dt_s > 0 ? delta.phi() * rs / dt_s : 0.0;
    // The first-order lag never quite reaches zero: below 1 mm/s and 0.06 deg/s counts as still.
    moving = dt_s > 0 && (std::hypot(delta.x(), delta.y()) / dt_s > 1e-3 ||
                          std::abs(delta.phi()) / dt_s > 1e-3);
  }

  void step_head(double dt_s) {
    const double max_step = deg_to_rad(mission->robot.pan_tilt.max_rate_dps) * dt_s;
    const JointAngles before = q_true;
    // Within one step of the command the joint lands on it exactly (no rounding creep).
    auto move = [max_step](double q, double target) {
      return std::abs(target - q) <= max_step ? target : q + std::copysign(max_step, target - q);
    };
    q_true.pan_rad = move(q_true.pan_rad, q_command.pan_rad);
    q_true.tilt_rad = move(q_true.tilt_rad, q_command.tilt_rad);
    head_moving_now = q_true.pan_rad != before.pan_rad || q_true.tilt_rad != before.tilt_rad;
    if (head_moving_now) at_rest_since_s = t_s;
    const double sigma = deg_to_rad(world.encoder_noise_deg);
    q_measured.pan_rad =
        q_true.pan_rad + deg_to_rad(world.encoder_bias_pan_deg) + sigma * gaussian(rng_encoder);
    q_measured.tilt_rad =
        q_true.tilt_rad + deg_to_rad(world.encoder_bias_tilt_deg) + sigma * gaussian(rng_encoder);
  }

  void simulate_scan() {
    const LaserSpec& spec = mission->robot.laser;
    LaserScan out;
    out.t_s = t_s;
    const double fov = deg_to_rad(spec.fov_deg);
    out.angle_min_rad = -0.5 * fov;
    out.angle_increment_rad = spec.rays > 1 ? fov / (spec.rays - 1) : 0.0;
    out.max_range_m = spec.max_range_m;
    out.T_base_laser = spec.T_base_laser;
    out.ranges_m.assign(static_cast<std::size_t>(std::max(spec.rays, 0)),
                        static_cast<float>(spec.max_range_m));
    out.valid.assign(out.ranges_m.size(), 0);
    const std::shared_ptr<mrpt::maps::COccupancyGridMap2D>& walls = laser_grid ? laser_grid : grid;
    if (walls && spec.rays > 0) {
      mrpt::obs::CObservation2DRangeScan obs;
      obs.aperture = static_cast<float>(fov);
      obs.maxRange = static_cast<float>(spec.max_range_m);
      obs.rightToLeft = true;
      obs.sensorPose = to_cpose3d(spec.T_base_laser);
      const Pose2D p = true_pose();
      // Noise is added here from the run's own stream: MRPT's would come from its global
      // generator, which other parts of the run share.
      walls->laserScanSimulator(obs, mrpt::poses::CPose2D(p.x_m, p.y_m, p.yaw_rad), laser_threshold,
                                static_cast<size_t>(spec.rays), 0.0f);
      const std::vector<double> near_m = unmapped_ranges(out, p);
      for (std::size_t i = 0; i < out.ranges_m.size() && i < obs.getScanSize(); ++i) {
        double r_true = obs.getScanRangeValidity(i) ? obs.getScanRange(i) : spec.max_range_m;
        if (!near_m.empty()) r_true = std::min(r_true, near_m[i]);
        if (r_true >= spec.max_range_m) continue;
        const double r = r_true + world.laser_range_noise_m * gaussian(rng_laser);
        if (r <= 0.0 || r >= spec.max_range_m) continue;
        out.ranges_m[i] = static_cast<float>(r);
        out.valid[i] = 1;
      }
    }
    scan = std::move(out);
  }

  // Per ray of `scan`, the range to the nearest unmapped object or person in the laser's plane
  // (infinity where none); empty when the building has none.
  std::vector<double> unmapped_ranges(const LaserScan& scan, const Pose2D& base) const {
    const bool people = crowd && !crowd->shapes().empty();
    if (footprints.empty() && !people) return {};
    const Eigen::Isometry3d T_map_laser = isometry_from_pose2d(base) * scan.T_base_laser;
    const double z = T_map_laser.translation().z();
    const Eigen::Vector2d origin = T_map_laser.translation().head<2>();
    const Eigen::Vector3d x_axis = T_map_laser.linear().col(0);
    const double yaw = std::atan2(x_axis.y(), x_axis.x());
    // Only what the laser can reach is looked at.
    std::vector<const Footprint*> reach;
    for (const Footprint& f : footprints) {
      if (z >= f.z_min_m && z <= f.z_max_m && f.distance_m(origin) < scan.max_range_m) {
        reach.push_back(&f);
      }
    }
    std::vector<Footprint> bodies;
    if (people) {
      for (const PersonShape& s : crowd->shapes()) {
        if (z > s.body_top_m) continue;
        Footprint f;
        f.shape = Footprint::Shape::circle;
        f.centre_m = s.centre_m.cast<double>();
        f.half_m = Eigen::Vector2d::Constant(s.radius_m);
        bodies.push_back(f);
      }
    }
    for (const Footprint& f : bodies) reach.push_back(&f);
    std::vector<double> out(scan.ranges_m.size(), std::numeric_limits<double>::infinity());
    if (reach.empty()) return out;
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double a = yaw + scan.angle_min_rad + static_cast<double>(i) * scan.angle_increment_rad;
      const Eigen::Vector2d dir(std::cos(a), std::sin(a));
      for (const Footprint* f : reach) out[i] = std::min(out[i], f->ray_hit_m(origin, dir));
    }
    return out;
  }

  // The referee, every sub-step: the robot's clearance to every unmapped object and person.
  void referee_clearance() {
    const Pose2D p = true_pose();
    const Eigen::Vector2d xy(p.x_m, p.y_m);
    double nearest = std::numeric_limits<double>::infinity();
    std::string what;
    for (const Footprint& f : footprints) {
      const double d = f.distance_m(xy);
      if (d < nearest) {
        nearest = d;
        what = f.name;
      }
    }
    if (crowd) {
      for (const PersonShape& s : crowd->shapes()) {
        const double d = (s.centre_m.cast<double>() - xy).norm() - s.radius_m;
        if (d < nearest) {
          nearest = d;
          what = "person " + std::to_string(s.object_id - kFirstPersonId);
        }
      }
    }
    if (!std::isfinite(nearest)) return;
    if (nearest < figures.min_clearance_m) {
      figures.min_clearance_m = nearest;
      figures.min_clearance_to = what;
    }
    const bool violation = nearest < robot_radius_m + kClearanceMarginM;
    if (violation && !in_violation) ++figures.clearance_violations;
    in_violation = violation;
  }

  // The referee, every tick: does the lit projector's light fall on anyone?
  void referee_light(double dt_s) {
    if (!lit || !crowd || crowd->shapes().empty() || shown.empty()) return;
    const Eigen::Isometry3d T_map_projector = T_map_base() * head_true->T_base_projector(q_true);
    const Eigen::Isometry3d T_projector_map = T_map_projector.inverse();
    const PinholeModel& k = mission->robot.projector.intrinsics;
    const Eigen::Vector3f origin = T_map_projector.translation().cast<float>();
    auto lit_at = [&](const Eigen::Vector3d& p_map, int object_id) {
      const Eigen::Vector3d p = T_projector_map * p_map;
      if (p.z() <= 0.0) return false;
      // Far off the axis the lens polynomial folds rays back into the image: only rays the
      // ideal pinhole puts near the image go through the distortion.
      const double u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
      if (u < -0.1 * k.width || u > 1.1 * k.width || v < -0.1 * k.height || v > 1.1 * k.height) {
        return false;
      }
      const auto px = k.project(p);
      if (!px || !k.in_image(*px)) return false;
      const cv::Vec3b c = shown.at<cv::Vec3b>(static_cast<int>(px->y()), static_cast<int>(px->x()));
      if (std::max({c[0], c[1], c[2]}) <= kLitLevel) return false;
      const Eigen::Vector3f dir = (p_map.cast<float>() - origin);
      RayHit hit;
      return scene.intersect(origin, dir, 1.0f + 1e-3f, hit) && hit.object_id == object_id;
    };
    bool head = false, body = false;
    for (const PersonShape& s : crowd->shapes()) {
      const Eigen::Vector3d c(s.centre_m.x(), s.centre_m.y(), s.head_z_m);
      // The head's near side, and round it: light through any of them reaches the face.
      const Eigen::Vector3d toward = (T_map_projector.translation() - c).normalized();
      const Eigen::Vector3d side = toward.cross(Eigen::Vector3d::UnitZ()).normalized();
      const double r = 0.9 * s.head_radius_m;
      for (const Eigen::Vector3d& q :
           {Eigen::Vector3d(c + r * toward), Eigen::Vector3d(c + r * side),
            Eigen::Vector3d(c - r * side), Eigen::Vector3d(c + Eigen::Vector3d(0, 0, r)),
            Eigen::Vector3d(c - Eigen::Vector3d(0, 0, r))}) {
        head = head || lit_at(q, s.object_id);
      }
      const Eigen::Vector2d to_projector =
          (T_map_projector.translation().head<2>() - s.centre_m.cast<double>()).normalized();
      for (double z = 0.1; z < s.body_top_m; z += 0.1) {
        const Eigen::Vector2d front = s.centre_m.cast<double>() + 0.95 * s.radius_m * to_projector;
        body = body || lit_at(Eigen::Vector3d(front.x(), front.y(), z), s.object_id);
      }
    }
    if (head) {
      ++figures.lit_on_head_ticks;
      figures.lit_on_head_s += dt_s;
    }
    if (head || body) {
      ++figures.lit_on_person_ticks;
      figures.lit_on_person_s += dt_s;
    }
  }

  void people_faults_if_due() {
    for (PersonFault& pf : person_faults) {
      if (pf.done) continue;
      const Target& t = targets[pf.target];
      if (!t.first_shown_s) continue;
      const FaultSpec& f = *pf.fault;
      const double start_s = *t.first_shown_s + fault_value(f, "after_s", 1.0);
      if (t_s + 1e-9 < start_s) continue;
      pf.done = true;
      const Eigen::Vector3d c3 = object(t).T_map_model.translation();
      const Eigen::Vector2d c(c3.x(), c3.y());
      Eigen::Vector2d toward(t.standoff.x_m - c.x(), t.standoff.y_m - c.y());
      toward = toward.norm() > 1e-9 ? toward.normalized() : Eigen::Vector2d::UnitX();
      const Eigen::Vector2d left(-toward.y(), toward.x());
      const double speed = fault_value(f, "speed_mps", 1.0);
      if (f.type == "person_standing") {
        const Eigen::Vector2d spot = c + fault_value(f, "distance_m", 0.5) * toward +
                                     fault_value(f, "offset_m", 0.0) * left;
        crowd->add_scripted({spot + 2.5 * left, spot, spot + 2.5 * left},
                            {0.0, fault_value(f, "for_s", 10.0), 0.0}, speed, t_s);
      } else {
        const Eigen::Vector2d mid = c + fault_value(f, "distance_m", 0.45) * toward;
        const int times = std::max(1, static_cast<int>(fault_value(f, "times", 1.0)));
        const double every_s = fault_value(f, "every_s", 8.0);
        for (int k = 0; k < times; ++k) {
          const double sign = k % 2 == 0 ? 1.0 : -1.0;
          crowd->add_scripted({mid + sign * 2.0 * left, mid - sign * 2.0 * left}, {}, speed,
                              t_s + k * every_s);
        }
      }
      for (std::size_t i = 0; colour_renderer && i < crowd->size(); ++i) {
        colour_renderer->set_albedo(kFirstPersonId + static_cast<int>(i), kPersonAlbedo);
      }
    }
  }

  void step_people(double dt_s) {
    if (!crowd) return;
    const Pose2D p = true_pose();
    crowd->step(t_s, dt_s, Eigen::Vector2d(p.x_m, p.y_m), robot_radius_m + kPeopleKeepOffM);
  }

  void kidnap_if_arrived() {
    Target* t = active();
    if (t == nullptr || t->kidnapped || moving) return;
    const FaultSpec* f = fault(t->spec->id, "kidnap");
    if (f == nullptr) return;
    const Pose2D p = true_pose();
    if (std::hypot(p.x_m - t->standoff.x_m, p.y_m - t->standoff.y_m) > 0.3) return;
    t->kidnapped = true;
    const double distance = fault_value(*f, "distance_m", 1.0);
    const double first = uniform(rng_faults, 0.0, 2.0 * kPi);
    // Look for a free spot in one of 16 directions, starting at a seeded one.
    for (int k = 0; k < 16; ++k) {
      const double a = first + k * kPi / 8.0;
      const Pose2D q{p.x_m + distance * std::cos(a), p.y_m + distance * std::sin(a),
                     wrap_angle_rad(p.yaw_rad + uniform(rng_faults, -0.5, 0.5))};
      if (!collides(q)) {
        vehicle.setCurrentGTPose(mrpt::math::TPose2D(q.x_m, q.y_m, q.yaw_rad));
        return;
      }
    }
  }

  // The camera's scene is rebuilt whenever a target moves (a BVH cannot move one object).
  void rebuild_scene() {
    SceneBuilder builder = fixed_parts;
    for (const Object& o : objects) {
      if (!o.missing) builder.add_mesh(*o.mesh, o.T_map_model, o.object_id);
    }
    scene = builder.build();
    if (crowd) scene.set_people(crowd->shapes());
    ++scene_version;
  }

  // A version for a camera at T_map_camera looking along its optical z: it changes with the
  // scene and with the people who may be in its view (coarsely: within 6 m and 80 deg of its
  // axis, which holds every camera here, whose half field of view is under 35 deg).
  std::uint64_t view_version(ViewKey& key, const Eigen::Isometry3d& T_map_camera) const {
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
    if (key.scene_version != scene_version || seen.size() != key.seen.size() ||
        !std::equal(seen.begin(), seen.end(), key.seen.begin(), same)) {
      ++key.counter;
      key.scene_version = scene_version;
      key.seen = std::move(seen);
    }
    return key.counter;
  }

  ColourRenderer& colour() const {
    if (!colour_renderer) {
      colour_renderer = std::make_unique<ColourRenderer>(mission->robot.camera.colour.intrinsics,
                                                         mission->robot.projector.intrinsics);
      colour_renderer->set_light(colour_light);
      colour_renderer->set_default_albedo(kTargetAlbedo);  // every target id
      colour_renderer->set_albedo(kFloorId, kFloorAlbedo);
      colour_renderer->set_albedo(kWallId, kWallAlbedo);
      colour_renderer->set_albedo(kObstacleId, kObstacleAlbedo);
      for (std::size_t i = 0; crowd && i < crowd->size(); ++i) {
        colour_renderer->set_albedo(kFirstPersonId + static_cast<int>(i), kPersonAlbedo);
      }
    }
    return *colour_renderer;
  }

  double max_colour_exposure_ms() const {
    return 1000.0 / std::max(mission->robot.camera.colour.rate_hz, 1e-9);
  }

  // The target's last frame, raw again if it was packed; empty when nothing was shown.
  cv::Mat last_frame(const Target& t) const {
    if (!t.last_frame.empty() || t.last_frame_png.empty()) return t.last_frame;
    return cv::imdecode(t.last_frame_png, cv::IMREAD_COLOR);
  }

  // The colour camera's view of the target with what was last shown on it, from where the robot
  // stood then, noise-free (the pictures are the same in every run of a seed).
  cv::Mat colour_panel(const Target& t,
                       const std::optional<std::array<Eigen::Vector2d, 4>>& observed_px) const {
    const cv::Mat frame = last_frame(t);
    const bool shown = !frame.empty() && t.last_shown_s;
    const Eigen::Isometry3d T_map_camera =
        shown ? t.T_map_camera_shown : T_map_base() * head_true->T_base_camera(q_true);
    const Eigen::Isometry3d T_map_projector =
        shown ? t.T_map_projector_shown : T_map_base() * head_true->T_base_projector(q_true);
    ColourRenderer& renderer = colour();
    cv::Mat radiance;
    renderer.render(scene, view_version(const_cast<Impl*>(this)->colour_view, T_map_camera),
                    T_map_camera, T_map_projector, shown ? &frame : nullptr, radiance);
    const double max_ms = max_colour_exposure_ms();
    const double fixed_ms = mission->robot.structured_light.exposure_ms;
    const double exposure_ms = fixed_ms > 0.0 ? std::min(fixed_ms, max_ms)
                                              : renderer.auto_exposure_ms(radiance, 0.1, max_ms);
    const ColourFrame image = renderer.expose(radiance, exposure_ms, nullptr);
    std::array<Eigen::Vector3d, 4> model_points_map;
    for (int i = 0; i < 4; ++i) {
      model_points_map[i] = object(t).T_map_model * t.spec->model_points[i];
    }
    std::ostringstream caption;
    caption.precision(1);
    caption << std::fixed;
    if (shown) {
      caption << "colour camera: as last shown, t = " << *t.last_shown_s << " s, " << exposure_ms
              << " ms";
    } else {
      caption << "colour camera: nothing shown on this target";
    }
    return colour_view_panel(image, T_map_camera, model_points_map, observed_px, caption.str());
  }

  void pack_last_frame(Target& t) {
    if (t.last_frame.empty()) return;
    // Fast, lossless compression: warped content is mostly black.
    cv::imencode(".png", t.last_frame, t.last_frame_png, {cv::IMWRITE_PNG_COMPRESSION, 1});
    t.last_frame.release();
  }

  void nudge_if_due() {
    Target* t = active();
    if (t == nullptr || t->nudged || !t->first_shown_s) return;
    const FaultSpec* f = fault(t->spec->id, "target_nudge");
    if (f == nullptr || t_s + 1e-9 < *t->first_shown_s + fault_value(*f, "after_s", 1.0)) return;
    t->nudged = true;
    Eigen::Vector3d shift_map;
    if (f->values.count("dx_m") || f->values.count("dy_m")) {
      shift_map = {fault_value(*f, "dx_m", 0.0), fault_value(*f, "dy_m", 0.0), 0.0};
    } else {
      const double distance_m = fault_value(*f, "distance_m", 0.02);
      const double direction_rad = deg_to_rad(fault_value(*f, "direction_deg", 90.0));
      shift_map = {distance_m * std::cos(direction_rad), distance_m * std::sin(direction_rad), 0.0};
    }
    Object& o = object(*t);  // a nudged target's object is its own (see Object::shared)
    o.T_map_model.pretranslate(shift_map);
    o.T_map_model.rotate(
        Eigen::AngleAxisd(deg_to_rad(fault_value(*f, "yaw_deg", 0.0)), Eigen::Vector3d::UnitZ()));
    alone_cache.reset();
    rebuild_scene();
  }

  Eigen::Isometry3d T_map_base() const { return isometry_from_pose2d(true_pose()); }

  Eigen::Isometry3d T_map_depth() const {
    // Capture builds its cloud as p_camera = p_depth + depth_to_color_m (the paper's eq. 2), so
    // the depth optical frame sits at +depth_to_color_m in the camera frame.
    Eigen::Isometry3d T_camera_depth = Eigen::Isometry3d::Identity();
    T_camera_depth.translation() = mission->robot.camera.depth_to_color_m;
    return T_map_base() * head_true->T_base_camera(q_true) * T_camera_depth;
  }

  void log_projector(bool shown) {
    const Target* t = active();
    ProjectorEvent e{t_s, shown, moving, head_moving_now, t ? t->spec->id : std::string()};
    projector_log.push_back(e);
    if (projector_jsonl.is_open()) {
      std::ostringstream line;
      line << "{\"t\": " << e.t_s << ", \"event\": \"" << (shown ? "show" : "blank")
           << "\", \"base_moving\": " << (e.base_moving ? "true" : "false")
           << ", \"head_moving\": " << (e.head_moving ? "true" : "false")
           << ", \"target\": " << (e.target.empty() ? std::string("null") : "\"" + e.target + "\"")
           << "}\n";
      // Called from the safe stop too, which must not throw: the log stops, said once.
      try {
        projector_jsonl.append(line.str());
      } catch (const std::exception& error) {
        std::cerr << "projtour: sim: " << error.what() << "; the projector log stops here\n";
        projector_jsonl = AppendOnlyFile();
      }
    }
  }
};

namespace {

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::map<const RunContext*, std::weak_ptr<SimWorld>>& registry() {
  static std::map<const RunContext*, std::weak_ptr<SimWorld>> r;
  return r;
}

}  // namespace

std::shared_ptr<SimWorld> SimWorld::attach(const RunContext& run) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto& slot = registry()[&run];
  if (auto world = slot.lock()) return world;
  auto world = std::make_shared<SimWorld>(run);
  slot = world;
  return world;
}

SimWorld::SimWorld(const RunContext& run) : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  if (run.mission == nullptr) throw std::invalid_argument("simulated world: no mission");
  w.run = &run;
  w.mission = run.mission;
  w.world = run.world ? *run.world : WorldSpec{};
  w.seed = run.seed;
  const RobotSpec& robot = run.mission->robot;
  std::mt19937_64 setup = stream(w.seed, Stream::setup);
  w.rng_odometry = stream(w.seed, Stream::odometry);
  w.rng_laser = stream(w.seed, Stream::laser);
  w.rng_encoder = stream(w.seed, Stream::encoder);
  w.rng_depth = stream(w.seed, Stream::depth);
  w.rng_faults = stream(w.seed, Stream::faults);
  w.rng_colour = stream(w.seed, Stream::colour);

  // Odometry: a per-run scale error between half and all of the configured fraction.
  w.odometry_trans_bias = w.world.odometry_trans_noise_frac * uniform(setup, 0.5, 1.0) *
                          (uniform(setup, 0, 1) < 0.5 ? -1.0 : 1.0);
  w.odometry_rot_bias = w.world.odometry_rot_noise_frac * uniform(setup, 0.5, 1.0) *
                        (uniform(setup, 0, 1) < 0.5 ? -1.0 : 1.0);

  // Calibration: the true projector mount is the robot file's moved by exactly the configured
  // error, in a seeded direction about a seeded axis.
  MountSpec projector_true = robot.projector.mount;
  Eigen::Isometry3d calib = Eigen::Isometry3d::Identity();
  calib.translation() = random_unit(setup) * (w.world.calibration_error_mm * 1e-3);
  calib.linear() = Eigen::AngleAxisd(deg_to_rad(w.world.calibration_error_deg), random_unit(setup))
                       .toRotationMatrix();
  projector_true.T_link_body = projector_true.T_link_body * calib;
  w.head_true =
      std::make_unique<HeadKinematics>(robot.pan_tilt, robot.camera.mount, projector_true);

  w.robot_radius_m = robot.base.radius_m;
  w.figures.min_clearance_m = std::numeric_limits<double>::infinity();
  std::mt19937_64 building = stream(w.seed, Stream::building);
  if (run.map) {
    w.grid = building_walls(*run.map, w.world.map_error,
                            Eigen::Vector2d(run.mission->start.x_m, run.mission->start.y_m));
  }
  // Glass: the building's walls the laser and the cameras see through (the bumper does not).
  auto without_glass = [&]() {
    auto seen = std::make_shared<mrpt::maps::COccupancyGridMap2D>(*w.grid);
    for (const WallSegmentSpec& g : w.world.glass) paint_segment(*seen, g, 1.0f);
    return seen;
  };
  for (std::size_t i = 0; i < w.world.glass.size(); ++i) {
    w.glass.push_back(glass_footprint(w.world.glass[i], "glass " + std::to_string(i)));
  }

  // Targets: true poses and true surfaces.
  SceneBuilder& builder = w.fixed_parts;
  builder.set_floor(0.0, kFloorId);
  if (w.grid)
    builder.add_occupancy_walls(w.glass.empty() ? *w.grid : *without_glass(), 2.0, kWallId);
  // By model file: targets may share one.
  std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
  for (std::size_t i = 0; i < run.mission->targets.size(); ++i) {
    const TargetSpec& spec = run.mission->targets[i];
    Impl::Target t;
    t.spec = &spec;
    t.standoff = standoff_pose(spec);
    Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
    const auto listed = w.world.T_map_model_true.find(spec.id);
    // Offsets are drawn for every target, listed or not, so listing one does not move another.
    const double r = w.world.target_offset_max_m * std::sqrt(uniform(setup, 0, 1));
    const double a = uniform(setup, 0, 2 * kPi);
    const double yaw = deg_to_rad(w.world.target_offset_max_deg) * uniform(setup, -1, 1);
    if (listed != w.world.T_map_model_true.end()) {
      T_map_model = listed->second;
    } else {
      Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
      shift.translation() = Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0.0);
      T_map_model = shift * spec.T_map_model * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    }
    const std::string key = spec.model.string();
    if (!meshes.count(key)) {
      try {
        meshes[key] = std::make_shared<const TriangleMesh>(load_mesh(spec.model));
      } catch (const std::exception& e) {
        throw std::runtime_error(std::string("simulated world: target '") + spec.id +
                                 "': the simulator renders meshes: " + e.what());
      }
    }
    const bool missing = w.fault(spec.id, "target_missing") != nullptr;
    const bool shareable = !missing && w.fault(spec.id, "target_nudge") == nullptr;
    t.object = w.objects.size();
    for (std::size_t k = 0; shareable && k < w.objects.size(); ++k) {
      const Impl::Object& o = w.objects[k];
      if (o.shared && o.model_key == key && o.T_map_model.matrix() == T_map_model.matrix()) {
        t.object = k;
        break;
      }
    }
    if (t.object == w.objects.size()) {
      Impl::Object o;
      o.mesh = w.world.model_error ? std::make_shared<const TriangleMesh>(perturbed_mesh(
                                         *meshes[key], w.world.model_error_noise_mm * 1e-3, setup))
                                   : meshes[key];
      o.T_map_model = T_map_model;
      o.object_id = kFirstTargetId + static_cast<int>(w.objects.size());
      o.model_key = key;
      o.missing = missing;
      o.shared = shareable;
      w.objects.push_back(std::move(o));
    }

    if (const FaultSpec* f = w.fault(spec.id, "occluder")) {
      // A board hanging above the laser plane between the target and its stand-off pose.
      const Eigen::Vector3d c = T_map_model.translation();
      Eigen::Vector2d dir(t.standoff.x_m - c.x(), t.standoff.y_m - c.y());
      dir = dir.norm() > 1e-9 ? dir.normalized() : Eigen::Vector2d::UnitX();
      const double d = fault_value(*f, "distance_m", 0.5);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = Eigen::AngleAxisd(std::atan2(dir.y(), dir.x()), Eigen::Vector3d::UnitZ())
                       .toRotationMatrix();
      T.translation() = Eigen::Vector3d(c.x() + d * dir.x(), c.y() + d * dir.y(), c.z());
      builder.add_box(T,
                      Eigen::Vector3d(0.01, 0.5 * fault_value(*f, "width_m", 0.4),
                                      0.5 * fault_value(*f, "height_m", 0.4)),
                      kObstacleId);
    }
    if (const FaultSpec* f = w.fault(spec.id, "blocked_path")) {
      const double half = 0.5 * fault_value(*f, "size_m", 0.6);
      Impl::Box2 box{{t.standoff.x_m - half, t.standoff.y_m - half},
                     {t.standoff.x_m + half, t.standoff.y_m + half}};
      w.obstacles.push_back(box);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = Eigen::Vector3d(t.standoff.x_m, t.standoff.y_m, 0.5);
      builder.add_box(T, Eigen::Vector3d(half, half, 0.5), kObstacleId);
      if (w.grid) {
        // Painted into the laser's grid too.
        for (double y = box.lo.y(); y <= box.hi.y(); y += 0.5 * w.grid->getResolution()) {
          for (double x = box.lo.x(); x <= box.hi.x(); x += 0.5 * w.grid->getResolution()) {
            const int i = w.grid->x2idx(x), j = w.grid->y2idx(y);
            if (i >= 0 && j >= 0 && i < static_cast<int>(w.grid->getSizeX()) &&
                j < static_cast<int>(w.grid->getSizeY())) {
              w.grid->setCell(i, j, 0.0f);
            }
          }
        }
      }
    }
    if (const FaultSpec* f = w.fault(spec.id, "pole")) {
      // Standing between the target and its stand-off pose: it takes the projector's light
      // meant for the target (and a shadow across it), and the depth camera sees it.
      const Eigen::Vector3d c = T_map_model.translation();
      Eigen::Vector2d dir(t.standoff.x_m - c.x(), t.standoff.y_m - c.y());
      dir = dir.norm() > 1e-9 ? dir.normalized() : Eigen::Vector2d::UnitX();
      const Eigen::Vector2d left(-dir.y(), dir.x());  // seen from the target, facing the robot
      const Eigen::Vector2d at = Eigen::Vector2d(c.x(), c.y()) +
                                 fault_value(*f, "distance_m", 0.6) * dir +
                                 fault_value(*f, "offset_m", 0.0) * left;
      const double radius_m = 0.5 * fault_value(*f, "diameter_m", 0.05);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = Eigen::Vector3d(at.x(), at.y(), 0.0);
      builder.add_mesh(prism_mesh(radius_m, kPoleHeight_m, kPoleSides), T, kObstacleId);
      // An obstacle for the bumper and the laser too, unless it stands where the robot must:
      // then it would be a blocked path, which is another fault's test.
      const double clearance_m = (at - Eigen::Vector2d(t.standoff.x_m, t.standoff.y_m)).norm();
      if (clearance_m > robot.base.radius_m + radius_m) {
        w.obstacles.push_back(
            {at - Eigen::Vector2d::Constant(radius_m), at + Eigen::Vector2d::Constant(radius_m)});
        if (w.grid) {
          // Every cell the pole's disc reaches (a 5 cm pole is at least the cell it stands in).
          const double res = w.grid->getResolution();
          const int i0 = w.grid->x2idx(at.x() - radius_m - res);
          const int i1 = w.grid->x2idx(at.x() + radius_m + res);
          const int j0 = w.grid->y2idx(at.y() - radius_m - res);
          const int j1 = w.grid->y2idx(at.y() + radius_m + res);
          for (int j = std::max(j0, 0); j <= std::min(j1, static_cast<int>(w.grid->getSizeY()) - 1);
               ++j) {
            for (int i = std::max(i0, 0);
                 i <= std::min(i1, static_cast<int>(w.grid->getSizeX()) - 1); ++i) {
              if (std::hypot(w.grid->idx2x(i) - at.x(), w.grid->idx2y(j) - at.y()) <=
                  radius_m + 0.5 * res) {
                w.grid->setCell(i, j, 0.0f);
              }
            }
          }
        }
      }
    }
    for (const FaultSpec& f : w.world.faults) {
      if (f.target == spec.id && (f.type == "person_standing" || f.type == "person_crossing")) {
        w.person_faults.push_back({i, &f, false});
      }
    }
    w.targets.push_back(std::move(t));
  }

  // The unmapped objects: listed, supports under the targets, clutter along the walls.
  std::vector<std::pair<WorldObjectSpec, std::string>> unmapped;
  for (std::size_t i = 0; i < w.world.objects.size(); ++i) {
    unmapped.emplace_back(w.world.objects[i], "object " + std::to_string(i));
  }
  if (w.world.supports) {
    for (const Impl::Object& o : w.objects) {
      if (o.missing) continue;
      std::string name = "support of " + o.model_key;
      for (const Impl::Target& t : w.targets) {
        if (t.object == static_cast<std::size_t>(&o - w.objects.data())) {
          name = "support of " + t.spec->id;
          break;
        }
      }
      for (const WorldObjectSpec& s : target_supports(*o.mesh, o.T_map_model)) {
        unmapped.emplace_back(s, name);
      }
    }
  }
  std::vector<Eigen::Vector2d> tour_places{{run.mission->start.x_m, run.mission->start.y_m}};
  for (const Impl::Target& t : w.targets) {
    tour_places.emplace_back(t.standoff.x_m, t.standoff.y_m);
    tour_places.push_back(w.object(t).T_map_model.translation().head<2>());
  }
  if (w.grid) {
    const auto clutter =
        place_clutter(*w.grid, w.world.clutter, tour_places, w.robot_radius_m, building);
    for (std::size_t i = 0; i < clutter.size(); ++i) {
      unmapped.emplace_back(clutter[i], "clutter " + std::to_string(i));
    }
  }
  for (const auto& [object, name] : unmapped) {
    w.footprints.push_back(object_footprint(object, name));
    add_object(builder, object, kObstacleId);
  }
  if (w.grid && !w.glass.empty()) w.laser_grid = without_glass();
  const bool people_faults = !w.person_faults.empty();
  if (w.world.people.walkers > 0 || !w.world.people.list.empty() || people_faults) {
    std::vector<Footprint> blocking = w.footprints;
    blocking.insert(blocking.end(), w.glass.begin(), w.glass.end());
    // Nobody walks through a target either (the beam guard could not tell them from it).
    for (const Impl::Object& o : w.objects) {
      if (o.missing) continue;
      if (auto f = target_footprint(*o.mesh, o.T_map_model, "target " + o.model_key)) {
        blocking.push_back(*f);
      }
    }
    std::vector<Eigen::Vector2d> homes;
    for (const Impl::Target& t : w.targets) homes.emplace_back(t.standoff.x_m, t.standoff.y_m);
    std::mt19937_64 people = stream(w.seed, Stream::people);
    w.crowd = std::make_unique<Crowd>(w.world.people, w.grid.get(), blocking, homes, kFirstPersonId,
                                      people());
  }
  w.rebuild_scene();
  w.depth_renderer = std::make_unique<DepthRenderer>(robot.camera.intrinsics);
  w.kinect.axial_noise = w.world.depth_noise;
  if (w.world.depth_artefacts) {
    w.kinect.shadows = true;
    w.kinect.flying_pixels = true;
    w.kinect.correlated_noise = w.world.depth_noise;
    // The Kinect's 9 px matching window is at 640 px across.
    w.kinect.correlation_window_px =
        std::max(1, static_cast<int>(std::lround(9.0 * robot.camera.intrinsics.width / 640.0)));
  }
  w.kinect.min_depth_m = robot.camera.min_range_m;
  w.kinect.max_depth_m = robot.camera.max_range_m;

  // Base: MRPT's simulator for the true motion; it starts where the mission says.
  w.vehicle.setOdometryErrors(false);
  w.vehicle.setDelayModelParams(0.1, 0.0);
  w.vehicle.setCurrentGTPose(mrpt::math::TPose2D(run.mission->start.x_m, run.mission->start.y_m,
                                                 run.mission->start.yaw_rad));
  w.odometry_pose = run.mission->start;

  const PanTiltSpec& pt = robot.pan_tilt;
  w.q_true = {deg_to_rad(pt.stow_pan_deg), deg_to_rad(pt.stow_tilt_deg)};
  w.q_command = w.q_true;
  w.q_measured = w.q_true;
}

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
    if (dt > 0.0) {
      w.step_base(dt);
      w.step_head(dt);
      w.step_people(dt);
      w.referee_clearance();
    }
    if (was_lit && (w.moving || w.head_moving_now)) w.lit_moving_s += dt;
  }
  w.t_s = t_s;
  if (dt_total <= 0.0) {
    w.step_head(0.0);
    w.step_people(0.0);
  }
  w.kidnap_if_arrived();
  w.nudge_if_due();
  if (w.crowd) {
    w.people_faults_if_due();
    if (w.crowd->moved()) {
      w.scene.set_people(w.crowd->shapes());
    }
    w.referee_light(dt_total);
  }

  const LaserSpec& laser = w.mission->robot.laser;
  if (t_s + 1e-9 >= w.next_scan_s) {
    w.simulate_scan();
    w.next_scan_s = (laser.rate_hz > 0 ? std::floor(t_s * laser.rate_hz + 1e-6) + 1.0 : 1.0) /
                    std::max(laser.rate_hz, 1e-9);
  }
  const CameraSpec& camera = w.mission->robot.camera;
  if (t_s + 1e-9 >= w.next_frame_s) {
    w.frame_due_s = t_s;
    w.next_frame_s =
        (std::floor(t_s * camera.rate_hz + 1e-6) + 1.0) / std::max(camera.rate_hz, 1e-9);
  }
  const double colour_hz = camera.colour.rate_hz;
  if (t_s + 1e-9 >= w.next_colour_frame_s) {
    w.colour_frame_due_s = t_s;
    w.next_colour_frame_s = (std::floor(t_s * colour_hz + 1e-6) + 1.0) / std::max(colour_hz, 1e-9);
  }
}

double SimWorld::time_s() const {
  return impl_->t_s;
}

void SimWorld::set_velocity_time_constant(double tau_s) {
  impl_->vehicle.setDelayModelParams(std::max(tau_s, 0.0), 0.0);
}

void SimWorld::command_velocity(double v_mps, double w_radps) {
  const BaseSpec& base = impl_->mission->robot.base;
  const double w_max = deg_to_rad(base.max_turn_rate_dps);
  impl_->vehicle.movementCommand(std::clamp(v_mps, -base.max_speed_mps, base.max_speed_mps),
                                 std::clamp(w_radps, -w_max, w_max));
}

Odometry SimWorld::odometry() const {
  return {impl_->t_s, impl_->odometry_pose, impl_->odometry_v, impl_->odometry_w};
}

bool SimWorld::base_blocked() const {
  return impl_->blocked;
}
bool SimWorld::base_moving() const {
  return impl_->moving;
}

void SimWorld::set_laser_occupancy_threshold(double threshold) {
  impl_->laser_threshold = static_cast<float>(threshold);
}

void SimWorld::set_max_incidence_deg(double deg) {
  impl_->kinect.max_incidence_deg = deg;
}

void SimWorld::set_projector_log_file(const std::filesystem::path& file) {
  if (file.has_parent_path()) make_run_directory(file.parent_path());
  impl_->projector_jsonl = AppendOnlyFile(file);
}

std::optional<LaserScan> SimWorld::take_scan() {
  auto out = std::move(impl_->scan);
  impl_->scan.reset();
  return out;
}

void SimWorld::set_head_settle_time(double settle_s) {
  impl_->settle_s = std::max(settle_s, 0.0);
}

void SimWorld::command_head(const JointAngles& angles) {
  const PanTiltSpec& pt = impl_->mission->robot.pan_tilt;
  impl_->q_command.pan_rad =
      std::clamp(angles.pan_rad, deg_to_rad(pt.pan_min_deg), deg_to_rad(pt.pan_max_deg));
  impl_->q_command.tilt_rad =
      std::clamp(angles.tilt_rad, deg_to_rad(pt.tilt_min_deg), deg_to_rad(pt.tilt_max_deg));
}

JointAngles SimWorld::measured_head() const {
  return impl_->q_measured;
}

bool SimWorld::head_reached() const {
  const Impl& w = *impl_;
  const double tol = deg_to_rad(w.mission->robot.pan_tilt.tolerance_deg);
  return std::abs(w.q_measured.pan_rad - w.q_command.pan_rad) <= tol &&
         std::abs(w.q_measured.tilt_rad - w.q_command.tilt_rad) <= tol && !w.head_moving_now &&
         w.t_s - w.at_rest_since_s >= w.settle_s - 1e-9;
}

bool SimWorld::head_moving() const {
  return impl_->head_moving_now;
}
JointAngles SimWorld::true_head() const {
  return impl_->q_true;
}

std::optional<DepthFrame> SimWorld::grab() {
  Impl& w = *impl_;
  Impl::Target* here = w.active();
  if (here != nullptr) {
    if (const FaultSpec* f = w.fault(here->spec->id, "camera_disconnect")) {
      if (here->frames_here >= static_cast<int>(fault_value(*f, "after_frames", 0.0))) {
        throw DriverError("simulated depth camera: device disconnected");
      }
    }
  }
  if (!w.frame_due_s) return std::nullopt;
  const double t_frame = *w.frame_due_s;
  w.frame_due_s.reset();
  const PinholeModel& k = w.mission->robot.camera.intrinsics;
  bool dropped = false;
  if (here != nullptr) {
    ++here->frames_here;
    if (const FaultSpec* f = w.fault(here->spec->id, "frame_dropout")) {
      dropped = uniform(w.rng_faults, 0.0, 1.0) < fault_value(*f, "fraction", 0.5);
    }
  }
  DepthFrame frame;
  if (dropped) {
    frame.intrinsics = k;
    frame.width = k.width;
    frame.height = k.height;
    frame.depth_mm.assign(static_cast<std::size_t>(k.width) * k.height, 0);
  } else {
    // A still camera in a still scene sees the same ideal image: only the noise is new (the
    // beam guard reads every frame of a dwell).
    const Eigen::Isometry3d T_map_depth = w.T_map_depth();
    const std::uint64_t version = w.view_version(w.depth_view, T_map_depth);
    if (!w.ideal_key || w.ideal_key->first != version ||
        !w.ideal_key->second.isApprox(T_map_depth, 0.0)) {
      w.depth_renderer->render(w.scene, T_map_depth, w.ideal, w.kinect.max_depth_m + 0.2);
      w.ideal_key.emplace(version, T_map_depth);
    }
    frame = apply_kinect_noise(w.ideal, k, w.kinect, w.rng_depth);
  }
  frame.t_s = t_frame;
  frame.sequence = ++w.frame_sequence;
  return frame;
}

void SimWorld::set_colour_light(const ColourLight& light) {
  impl_->colour_light = light;
  if (impl_->colour_renderer) impl_->colour_renderer->set_light(light);
}

void SimWorld::set_colour_exposure_ms(double exposure_ms) {
  if (!(exposure_ms >= 0.0) || !std::isfinite(exposure_ms)) {
    throw std::invalid_argument(
        "simulated colour camera: exposure must be >= 0 ms (0 = automatic)");
  }
  impl_->colour_exposure_ms = exposure_ms;
}

std::optional<ColourFrame> SimWorld::grab_colour() {
  Impl& w = *impl_;
  Impl::Target* here = w.active();
  if (here != nullptr) {
    // One device: the Kinect's colour stream goes with its depth stream, each after as many of
    // its own frames.
    if (const FaultSpec* f = w.fault(here->spec->id, "camera_disconnect")) {
      if (here->colour_frames_here >= static_cast<int>(fault_value(*f, "after_frames", 0.0))) {
        throw DriverError("simulated colour camera: device disconnected");
      }
    }
  }
  if (!w.colour_frame_due_s) return std::nullopt;
  const double t_frame = *w.colour_frame_due_s;
  w.colour_frame_due_s.reset();
  if (here != nullptr) ++here->colour_frames_here;
  ColourRenderer& renderer = w.colour();
  ColourLight light = w.colour_light;
  if (here != nullptr) {
    if (const FaultSpec* f = w.fault(here->spec->id, "daylight")) {
      light.room_lux = fault_value(*f, "lux", 20000.0);
    }
  }
  // set_light drops the kept geometry: only when the light really changes.
  if (light.room_lux != renderer.light().room_lux) renderer.set_light(light);
  renderer.render(w.scene, w.view_version(w.colour_view, true_T_map_camera()), true_T_map_camera(),
                  true_T_map_projector(), w.lit ? &w.shown : nullptr, w.colour_radiance);
  const double max_ms = w.max_colour_exposure_ms();
  const double exposure_ms = w.colour_exposure_ms > 0.0
                                 ? std::min(w.colour_exposure_ms, max_ms)
                                 : renderer.auto_exposure_ms(w.colour_radiance, 0.1, max_ms);
  ColourFrame frame = renderer.expose(w.colour_radiance, exposure_ms, &w.rng_colour);
  frame.t_s = t_frame;
  frame.sequence = ++w.colour_sequence;
  return frame;
}

void SimWorld::show(const cv::Mat& frame_bgr) {
  Impl& w = *impl_;
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
  Impl::Target* here = w.active();
  if (here != nullptr) {
    if (const FaultSpec* f = w.fault(here->spec->id, "projector_failure")) {
      if (here->shows_here >= static_cast<int>(fault_value(*f, "after_shows", 0.0))) {
        throw DriverError("simulated projector: lamp failure");
      }
    }
    ++here->shows_here;
    if (!here->first_shown_s) here->first_shown_s = w.t_s;
  }
  // A copy: the caller may draw the next frame into the same buffer.
  if (type == CV_8UC3) {
    frame_bgr.copyTo(w.shown);
  } else {
    cv::cvtColor(frame_bgr, w.shown, type == CV_8UC1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  }
  if (here != nullptr) {
    const auto index = static_cast<std::size_t>(here - w.targets.data());
    if (w.last_lit && *w.last_lit != index) w.pack_last_frame(w.targets[*w.last_lit]);
    w.last_lit = index;
    w.shown.copyTo(here->last_frame);
    here->last_frame_png.clear();
    here->T_map_camera_shown = true_T_map_camera();
    here->T_map_projector_shown = true_T_map_projector();
    here->last_shown_s = w.t_s;
  }
  w.lit = true;
  w.log_projector(true);
}

void SimWorld::blank() {
  impl_->lit = false;
  impl_->log_projector(false);
}

bool SimWorld::is_blank() const {
  return !impl_->lit;
}
const std::vector<ProjectorEvent>& SimWorld::projector_log() const {
  return impl_->projector_log;
}
double SimWorld::lit_while_moving_s() const {
  return impl_->lit_moving_s;
}

std::string SimWorld::active_target() const {
  const Impl::Target* t = impl_->active();
  return t ? t->spec->id : std::string();
}

const TriangleMesh& SimWorld::true_mesh(const std::string& target_id) const {
  const Impl::Target* t = impl_->target(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  return *impl_->object(*t).mesh;
}

void SimWorld::set_true_base_pose(const Pose2D& pose) {
  impl_->vehicle.setCurrentGTPose(mrpt::math::TPose2D(pose.x_m, pose.y_m, pose.yaw_rad));
}

Eigen::Isometry3d SimWorld::true_T_map_base() const {
  return impl_->T_map_base();
}

Eigen::Isometry3d SimWorld::true_T_map_base_as_drawn() const {
  const Pose2D p = impl_->true_pose();
  const MapErrorSpec& error = impl_->world.map_error;
  const Eigen::Vector2d on_map =
      map_point_of(Eigen::Vector2d(p.x_m, p.y_m), error,
                   Eigen::Vector2d(impl_->mission->start.x_m, impl_->mission->start.y_m));
  return isometry_from_pose2d(
      Pose2D{on_map.x(), on_map.y(), wrap_angle_rad(p.yaw_rad - deg_to_rad(error.rotation_deg))});
}

Eigen::Isometry3d SimWorld::true_T_map_camera() const {
  return impl_->T_map_base() * impl_->head_true->T_base_camera(impl_->q_true);
}

Eigen::Isometry3d SimWorld::true_T_map_projector() const {
  return impl_->T_map_base() * impl_->head_true->T_base_projector(impl_->q_true);
}

Eigen::Isometry3d SimWorld::true_T_map_model(const std::string& target_id) const {
  const Impl::Target* t = impl_->target(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  return impl_->object(*t).T_map_model;
}

std::optional<ProjectionTruth> SimWorld::evaluate_projection(
    const std::string& target_id, const std::array<Eigen::Vector2d, 4>& projector_px) const {
  const Impl::Target* t = impl_->target(target_id);
  if (t == nullptr) return std::nullopt;
  const TrueProjection truth = true_projection(
      *t->spec, impl_->object(*t).T_map_model, impl_->alone(*t), true_T_map_projector(),
      impl_->mission->robot.projector.intrinsics, projector_px);
  ProjectionTruth out;
  for (int i = 0; i < 4; ++i) {
    out.error_mm[i] = truth.error_mm(i);
    out.error_px[i] = truth.error_px[i];
  }
  const Impl::Object& object = impl_->object(*t);
  const AreaFigures area = area_figures(*t->spec, object.T_map_model, impl_->alone(*t),
                                        impl_->scene, object.object_id, true_T_map_projector(),
                                        impl_->mission->robot.projector.intrinsics, projector_px);
  out.area_error_mean_mm = area.error_mean_mm;
  out.area_error_max_mm = area.error_max_mm;
  out.light_off_target_fraction = area.light_off_target_fraction;
  return out;
}

void SimWorld::set_visited_target(const std::string& target_id) {
  const Impl::Target* t = impl_->target(target_id);
  impl_->visited.reset();
  if (t != nullptr) impl_->visited = static_cast<std::size_t>(t - impl_->targets.data());
}

void SimWorld::write_projection_views(
    const std::string& target_id, const std::array<Eigen::Vector2d, 4>& pixels_before_align,
    const std::array<Eigen::Vector2d, 4>& pixels_after_align,
    const std::optional<std::array<Eigen::Vector2d, 4>>& observed_colour_px,
    const std::filesystem::path& dir) const {
  const Impl::Target* t = impl_->target(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  const Eigen::Isometry3d T_map_projector = true_T_map_projector();
  const PinholeModel& k = impl_->mission->robot.projector.intrinsics;
  const Eigen::Isometry3d& T_map_model = impl_->object(*t).T_map_model;
  const Scene& alone = impl_->alone(*t);
  const cv::Mat colour_view = impl_->colour_panel(*t, observed_colour_px);
  make_run_directory(dir);
  write_projection_view(
      alone, T_map_model,
      true_projection(*t->spec, T_map_model, alone, T_map_projector, k, pixels_before_align),
      "before alignment", colour_view, dir / "before.png");
  write_projection_view(
      alone, T_map_model,
      true_projection(*t->spec, T_map_model, alone, T_map_projector, k, pixels_after_align),
      "after alignment", colour_view, dir / "after.png");
}

std::vector<Eigen::Vector2d> SimWorld::people_positions() const {
  std::vector<Eigen::Vector2d> out;
  if (impl_->crowd) {
    for (const auto& [index, at] : impl_->crowd->positions()) out.push_back(at);
  }
  return out;
}

std::optional<BuildingTruth> SimWorld::building_truth() const {
  const Impl& w = *impl_;
  if (!w.crowd && w.footprints.empty()) return std::nullopt;
  BuildingTruth out = w.figures;
  out.people = w.crowd ? static_cast<int>(w.crowd->size()) : 0;
  out.unmapped_objects = static_cast<int>(w.footprints.size());
  out.required_clearance_m = w.robot_radius_m + kClearanceMarginM;
  return out;
}

}  // namespace projtour::sim
