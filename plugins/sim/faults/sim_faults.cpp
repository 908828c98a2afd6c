// The world file's faults at work (sim_faults.hpp). Every number not written in the world file
// is the fault table's default (projtour/host/world_faults.hpp).
#include "faults/sim_faults.hpp"

#include <algorithm>
#include <cmath>

#include "bodies/body_ids.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/host/world_faults.hpp"
#include "world/random_streams.hpp"

namespace projtour::sim {
namespace {

// The pole fault's shape: a 16-sided prism is round to within 2 % of its diameter.
constexpr int kPoleSides = 16;
constexpr double kPoleHeight_m = 2.0;
// person_standing's walker comes and goes at a walk (the fault has no speed of its own).
constexpr double kStandingWalkSpeed_mps = 1.0;

// From the target toward its stand-off pose, in the map's plane (the map's +x when they meet).
Eigen::Vector2d toward_standoff(const Eigen::Vector3d& c, const Pose2D& standoff) {
  Eigen::Vector2d dir(standoff.x_m - c.x(), standoff.y_m - c.y());
  return dir.norm() > 1e-9 ? dir.normalized() : Eigen::Vector2d::UnitX();
}

}  // namespace

const host::FaultSpec* SimFaults::find(const std::string& target_id,
                                       const std::string& type) const {
  for (const auto& f : *faults_) {
    if (f.target == target_id && f.type == type) return &f;
  }
  return nullptr;
}

TargetFaultFlags SimFaults::flags(const std::string& target_id) const {
  TargetFaultFlags out;
  out.missing = find(target_id, "target_missing") != nullptr;
  out.shareable = !out.missing && find(target_id, "target_nudge") == nullptr;
  return out;
}

void SimFaults::place(const TrueTargets& targets, WorldBodies& bodies) {
  for (std::size_t i = 0; i < targets.targets.size(); ++i) {
    const TrueTarget& t = targets.targets[i];
    const Eigen::Isometry3d& T_map_model = targets.object(t).T_map_model;
    if (const host::FaultSpec* f = find(t.spec->id, "occluder")) {
      place_occluder(*f, t, T_map_model, bodies);
    }
    if (const host::FaultSpec* f = find(t.spec->id, "blocked_path"))
      place_blocked_path(*f, t, bodies);
    if (const host::FaultSpec* f = find(t.spec->id, "pole")) place_pole(*f, t, T_map_model, bodies);
    for (const host::FaultSpec& f : *faults_) {
      if (f.target == t.spec->id && (f.type == "person_standing" || f.type == "person_crossing")) {
        person_faults_.push_back({i, &f, false});
      }
    }
  }
}

// A board hanging above the laser plane between the target and its stand-off pose.
void SimFaults::place_occluder(const host::FaultSpec& f, const TrueTarget& t,
                               const Eigen::Isometry3d& T_map_model, WorldBodies& bodies) const {
  const Eigen::Vector3d c = T_map_model.translation();
  const Eigen::Vector2d dir = toward_standoff(c, t.standoff);
  const double d = host::fault_number(f, "distance_m");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(std::atan2(dir.y(), dir.x()), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(c.x() + d * dir.x(), c.y() + d * dir.y(), c.z());
  bodies.fixed_parts.add_box(T,
                             Eigen::Vector3d(0.01, 0.5 * host::fault_number(f, "width_m"),
                                             0.5 * host::fault_number(f, "height_m")),
                             kObstacleId);
}

void SimFaults::place_blocked_path(const host::FaultSpec& f, const TrueTarget& t,
                                   WorldBodies& bodies) const {
  const double half = 0.5 * host::fault_number(f, "size_m");
  const Box2 box{{t.standoff.x_m - half, t.standoff.y_m - half},
                 {t.standoff.x_m + half, t.standoff.y_m + half}};
  bodies.obstacles.push_back(box);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(t.standoff.x_m, t.standoff.y_m, 0.5);
  bodies.fixed_parts.add_box(T, Eigen::Vector3d(half, half, 0.5), kObstacleId);
  if (!bodies.grid) return;
  // Painted into the laser's grid too.
  auto& grid = *bodies.grid;
  for (double y = box.lo.y(); y <= box.hi.y(); y += 0.5 * grid.getResolution()) {
    for (double x = box.lo.x(); x <= box.hi.x(); x += 0.5 * grid.getResolution()) {
      const int i = grid.x2idx(x), j = grid.y2idx(y);
      if (i >= 0 && j >= 0 && i < static_cast<int>(grid.getSizeX()) &&
          j < static_cast<int>(grid.getSizeY())) {
        grid.setCell(i, j, 0.0f);
      }
    }
  }
}

// Standing between the target and its stand-off pose: it takes the projector's light meant for
// the target (and a shadow across it), and the depth camera sees it.
void SimFaults::place_pole(const host::FaultSpec& f, const TrueTarget& t,
                           const Eigen::Isometry3d& T_map_model, WorldBodies& bodies) const {
  const Eigen::Vector3d c = T_map_model.translation();
  const Eigen::Vector2d dir = toward_standoff(c, t.standoff);
  const Eigen::Vector2d left(-dir.y(), dir.x());  // seen from the target, facing the robot
  const Eigen::Vector2d at = Eigen::Vector2d(c.x(), c.y()) +
                             host::fault_number(f, "distance_m") * dir +
                             host::fault_number(f, "offset_m") * left;
  const double radius_m = 0.5 * host::fault_number(f, "diameter_m");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(at.x(), at.y(), 0.0);
  bodies.fixed_parts.add_mesh(prism_mesh(radius_m, kPoleHeight_m, kPoleSides), T, kObstacleId);
  // An obstacle for the bumper and the laser too, unless it stands where the robot must: then
  // it would be a blocked path, which is another fault's test.
  const double clearance_m = (at - Eigen::Vector2d(t.standoff.x_m, t.standoff.y_m)).norm();
  if (clearance_m <= bodies.robot_radius_m + radius_m) return;
  bodies.obstacles.push_back(
      {at - Eigen::Vector2d::Constant(radius_m), at + Eigen::Vector2d::Constant(radius_m)});
  if (!bodies.grid) return;
  // Every cell the pole's disc reaches (a 5 cm pole is at least the cell it stands in).
  auto& grid = *bodies.grid;
  const double res = grid.getResolution();
  const int i0 = grid.x2idx(at.x() - radius_m - res), i1 = grid.x2idx(at.x() + radius_m + res);
  const int j0 = grid.y2idx(at.y() - radius_m - res), j1 = grid.y2idx(at.y() + radius_m + res);
  for (int j = std::max(j0, 0); j <= std::min(j1, static_cast<int>(grid.getSizeY()) - 1); ++j) {
    for (int i = std::max(i0, 0); i <= std::min(i1, static_cast<int>(grid.getSizeX()) - 1); ++i) {
      if (std::hypot(grid.idx2x(i) - at.x(), grid.idx2y(j) - at.y()) <= radius_m + 0.5 * res) {
        grid.setCell(i, j, 0.0f);
      }
    }
  }
}

void SimFaults::kidnap_if_arrived(TrueTarget* t, SimBaseBody& base,
                                  const std::function<bool(const Pose2D&)>& collides,
                                  std::mt19937_64& rng) const {
  if (t == nullptr || t->kidnapped || base.moving) return;
  const host::FaultSpec* f = find(t->spec->id, "kidnap");
  if (f == nullptr) return;
  const Pose2D p = base.true_pose();
  if (std::hypot(p.x_m - t->standoff.x_m, p.y_m - t->standoff.y_m) > 0.3) return;
  t->kidnapped = true;
  const double distance = host::fault_number(*f, "distance_m");
  const double first = uniform(rng, 0.0, 2.0 * kPi);
  // Look for a free spot in one of 16 directions, starting at a seeded one.
  for (int k = 0; k < 16; ++k) {
    const double a = first + k * kPi / 8.0;
    const Pose2D q{p.x_m + distance * std::cos(a), p.y_m + distance * std::sin(a),
                   wrap_angle_rad(p.yaw_rad + uniform(rng, -0.5, 0.5))};
    if (!collides(q)) {
      base.vehicle.setCurrentGTPose(mrpt::math::TPose2D(q.x_m, q.y_m, q.yaw_rad));
      return;
    }
  }
}

bool SimFaults::nudge_if_due(TrueTarget* t, TrueTargets& targets, double t_s) const {
  if (t == nullptr || t->nudged || !t->first_shown_s) return false;
  const host::FaultSpec* f = find(t->spec->id, "target_nudge");
  if (f == nullptr || t_s + 1e-9 < *t->first_shown_s + host::fault_number(*f, "after_s"))
    return false;
  t->nudged = true;
  Eigen::Vector3d shift_map;
  if (f->values.count("dx_m") || f->values.count("dy_m")) {
    shift_map = {host::fault_number(*f, "dx_m"), host::fault_number(*f, "dy_m"), 0.0};
  } else {
    const double distance_m = host::fault_number(*f, "distance_m");
    const double direction_rad = deg_to_rad(host::fault_number(*f, "direction_deg"));
    shift_map = {distance_m * std::cos(direction_rad), distance_m * std::sin(direction_rad), 0.0};
  }
  TrueObject& o = targets.object(*t);  // a nudged target's object is its own (TrueObject::shared)
  o.T_map_model.pretranslate(shift_map);
  o.T_map_model.rotate(
      Eigen::AngleAxisd(deg_to_rad(host::fault_number(*f, "yaw_deg")), Eigen::Vector3d::UnitZ()));
  targets.alone_cache.reset();
  return true;
}

bool SimFaults::people_if_due(const TrueTargets& targets, Crowd& crowd, double t_s) {
  bool added = false;
  for (PersonFault& pf : person_faults_) {
    if (pf.done) continue;
    const TrueTarget& t = targets.targets[pf.target];
    if (!t.first_shown_s) continue;
    const host::FaultSpec& f = *pf.fault;
    const double start_s = *t.first_shown_s + host::fault_number(f, "after_s");
    if (t_s + 1e-9 < start_s) continue;
    pf.done = true;
    added = true;
    const Eigen::Vector3d c3 = targets.object(t).T_map_model.translation();
    const Eigen::Vector2d c(c3.x(), c3.y());
    const Eigen::Vector2d toward = toward_standoff(c3, t.standoff);
    const Eigen::Vector2d left(-toward.y(), toward.x());
    if (f.type == "person_standing") {
      const Eigen::Vector2d spot = c + host::fault_number(f, "distance_m") * toward +
                                   host::fault_number(f, "offset_m") * left;
      crowd.add_scripted({spot + 2.5 * left, spot, spot + 2.5 * left},
                         {0.0, host::fault_number(f, "for_s"), 0.0}, kStandingWalkSpeed_mps, t_s);
    } else {
      const Eigen::Vector2d mid = c + host::fault_number(f, "distance_m") * toward;
      const int times = std::max(1, static_cast<int>(host::fault_number(f, "times")));
      const double every_s = host::fault_number(f, "every_s");
      const double speed = host::fault_number(f, "speed_mps");
      for (int k = 0; k < times; ++k) {
        const double sign = k % 2 == 0 ? 1.0 : -1.0;
        crowd.add_scripted({mid + sign * 2.0 * left, mid - sign * 2.0 * left}, {}, speed,
                           t_s + k * every_s);
      }
    }
  }
  return added;
}

bool SimFaults::depth_disconnected(const TrueTarget* here) const {
  if (here == nullptr) return false;
  const host::FaultSpec* f = find(here->spec->id, "camera_disconnect");
  return f != nullptr &&
         here->frames_here >= static_cast<int>(host::fault_number(*f, "after_frames"));
}

// One device: the Kinect's colour stream goes with its depth stream, each after as many of its
// own frames.
bool SimFaults::colour_disconnected(const TrueTarget* here) const {
  if (here == nullptr) return false;
  const host::FaultSpec* f = find(here->spec->id, "camera_disconnect");
  return f != nullptr &&
         here->colour_frames_here >= static_cast<int>(host::fault_number(*f, "after_frames"));
}

bool SimFaults::projector_failed(const TrueTarget* here) const {
  if (here == nullptr) return false;
  const host::FaultSpec* f = find(here->spec->id, "projector_failure");
  return f != nullptr &&
         here->shows_here >= static_cast<int>(host::fault_number(*f, "after_shows"));
}

bool SimFaults::frame_dropped(const TrueTarget* here, std::mt19937_64& rng) const {
  if (here == nullptr) return false;
  const host::FaultSpec* f = find(here->spec->id, "frame_dropout");
  return f != nullptr && uniform(rng, 0.0, 1.0) < host::fault_number(*f, "fraction");
}

std::optional<double> SimFaults::daylight_lux(const TrueTarget* here) const {
  if (here == nullptr) return std::nullopt;
  const host::FaultSpec* f = find(here->spec->id, "daylight");
  if (f == nullptr) return std::nullopt;
  return host::fault_number(*f, "lux");
}

}  // namespace projtour::sim
