// What stands in the building: the bumper's and the laser's questions.
#include "bodies/world_bodies.hpp"

#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "projtour/contract/geometry.hpp"
#include "world/random_streams.hpp"

namespace projtour::sim {
namespace {

mrpt::poses::CPose3D to_cpose3d(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d ypr = T.linear().eulerAngles(2, 1, 0);
  const Eigen::Vector3d t = T.translation();
  return mrpt::poses::CPose3D(t.x(), t.y(), t.z(), ypr[0], ypr[1], ypr[2]);
}

}  // namespace

bool WorldBodies::collides(const Pose2D& p, double collision_radius_m,
                           const std::vector<PersonShape>* people) const {
  const Eigen::Vector2d xy(p.x_m, p.y_m);
  for (const auto* list : {&footprints, &glass}) {
    for (const Footprint& f : *list) {
      if (f.distance_m(xy) < robot_radius_m) return true;
    }
  }
  if (people) {
    for (const PersonShape& s : *people) {
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

LaserScan WorldBodies::simulate_scan(const LaserSpec& spec, double t_s, const Pose2D& p,
                                     float threshold, double noise_m,
                                     const std::vector<PersonShape>* people,
                                     std::mt19937_64& rng) const {
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
  if (!walls || spec.rays <= 0) return out;
  mrpt::obs::CObservation2DRangeScan obs;
  obs.aperture = static_cast<float>(fov);
  obs.maxRange = static_cast<float>(spec.max_range_m);
  obs.rightToLeft = true;
  obs.sensorPose = to_cpose3d(spec.T_base_laser);
  // Noise is added here from the run's own stream: MRPT's would come from its global
  // generator, which other parts of the run share.
  walls->laserScanSimulator(obs, mrpt::poses::CPose2D(p.x_m, p.y_m, p.yaw_rad), threshold,
                            static_cast<size_t>(spec.rays), 0.0f);
  const std::vector<double> near_m = unmapped_ranges(out, p, people);
  for (std::size_t i = 0; i < out.ranges_m.size() && i < obs.getScanSize(); ++i) {
    double r_true = obs.getScanRangeValidity(i) ? obs.getScanRange(i) : spec.max_range_m;
    if (!near_m.empty()) r_true = std::min(r_true, near_m[i]);
    if (r_true >= spec.max_range_m) continue;
    const double r = r_true + noise_m * gaussian(rng);
    if (r <= 0.0 || r >= spec.max_range_m) continue;
    out.ranges_m[i] = static_cast<float>(r);
    out.valid[i] = 1;
  }
  return out;
}

std::vector<double> WorldBodies::unmapped_ranges(const LaserScan& scan, const Pose2D& base,
                                                 const std::vector<PersonShape>* people) const {
  const bool any_people = people && !people->empty();
  if (footprints.empty() && !any_people) return {};
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
  if (any_people) {
    for (const PersonShape& s : *people) {
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

}  // namespace projtour::sim
