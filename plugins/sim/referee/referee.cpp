// The referee of the building: clearance and light on people.
#include "referee/referee.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "bodies/body_ids.hpp"

namespace projtour::sim {
namespace {

// What counts as lit in a projector frame: above the black level of a blanked pixel.
constexpr int kLitLevel = 8;

}  // namespace

BuildingReferee::BuildingReferee() {
  figures_.min_clearance_m = std::numeric_limits<double>::infinity();
}

void BuildingReferee::clearance(const Eigen::Vector2d& xy, const std::vector<Footprint>& footprints,
                                const std::vector<PersonShape>* people, double robot_radius_m) {
  double nearest = std::numeric_limits<double>::infinity();
  std::string what;
  for (const Footprint& f : footprints) {
    const double d = f.distance_m(xy);
    if (d < nearest) {
      nearest = d;
      what = f.name;
    }
  }
  if (people) {
    for (const PersonShape& s : *people) {
      const double d = (s.centre_m.cast<double>() - xy).norm() - s.radius_m;
      if (d < nearest) {
        nearest = d;
        what = "person " + std::to_string(s.object_id - kFirstPersonId);
      }
    }
  }
  if (!std::isfinite(nearest)) return;
  if (nearest < figures_.min_clearance_m) {
    figures_.min_clearance_m = nearest;
    figures_.min_clearance_to = what;
  }
  const bool violation = nearest < robot_radius_m + kClearanceMarginM;
  if (violation && !in_violation_) ++figures_.clearance_violations;
  in_violation_ = violation;
}

void BuildingReferee::light(double dt_s, const cv::Mat& shown,
                            const Eigen::Isometry3d& T_map_projector, const PinholeModel& k,
                            const Scene& scene, const std::vector<PersonShape>& people) {
  const Eigen::Isometry3d T_projector_map = T_map_projector.inverse();
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
  for (const PersonShape& s : people) {
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
    ++figures_.lit_on_head_ticks;
    figures_.lit_on_head_s += dt_s;
  }
  if (head || body) {
    ++figures_.lit_on_person_ticks;
    figures_.lit_on_person_s += dt_s;
  }
}

}  // namespace projtour::sim
