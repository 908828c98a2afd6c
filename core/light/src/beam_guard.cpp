// The beam guard (see beam_guard.hpp).
#include "projtour/beam_guard.hpp"

#include <algorithm>
#include <cmath>

namespace projtour::light {

BeamGuard::BeamGuard(const BeamGuardSettings& settings) : settings_(settings) {}

void BeamGuard::arm(const Eigen::Isometry3d& T_projector_camera, const PinholeModel& projector,
                    const std::array<Eigen::Vector2d, 4>& lit_px, const ModelCloud& model,
                    const Eigen::Isometry3d& T_camera_model) {
  T_projector_camera_ = T_projector_camera;
  // The ideal pinhole: the guard band is far wider than the lens distortion's few pixels.
  fx_ = projector.fx;
  fy_ = projector.fy;
  cx_ = projector.cx;
  cy_ = projector.cy;
  // Winding from the signed area, so the normals point inside either way round.
  double area2 = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d& a = lit_px[i];
    const Eigen::Vector2d& b = lit_px[(i + 1) % 4];
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  const double inside = area2 >= 0.0 ? 1.0 : -1.0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d edge = lit_px[(i + 1) % 4] - lit_px[i];
    Eigen::Vector2d n(-edge.y(), edge.x());
    n *= inside / std::max(n.norm(), 1e-12);
    normal_[i] = n;
    offset_[i] = n.dot(lit_px[i]);
  }
  // The target's nearest point inside the grown region sets the limit; with none there (the
  // model out of view), its nearest point at all.
  const Eigen::Isometry3d T_projector_model = T_projector_camera * T_camera_model;
  double nearest_in = std::numeric_limits<double>::infinity();
  double nearest_any = nearest_in;
  for (const Eigen::Vector3f& p : model.points) {
    const Eigen::Vector3d q = T_projector_model * p.cast<double>();
    if (q.z() <= 0.0) continue;
    nearest_any = std::min(nearest_any, q.z());
    if (in_region({fx_ * q.x() / q.z() + cx_, fy_ * q.y() / q.z() + cy_}, q.z())) {
      nearest_in = std::min(nearest_in, q.z());
    }
  }
  const double nearest = std::isfinite(nearest_in) ? nearest_in : nearest_any;
  limit_m_ = std::isfinite(nearest) ? nearest - settings_.margin_m : 0.0;
  armed_ = limit_m_ > settings_.min_range_m;
}

bool BeamGuard::in_region(const Eigen::Vector2d& px, double z_m) const {
  const double guard_px = fx_ * settings_.guard_m / z_m;
  for (int i = 0; i < 4; ++i) {
    if (normal_[i].dot(px) < offset_[i] - guard_px) return false;
  }
  return true;
}

BeamIntrusion BeamGuard::check(const DepthFrame& frame,
                               const Eigen::Vector3d& depth_to_color_m) const {
  BeamIntrusion out;
  if (!armed_ || frame.width <= 0 || frame.height <= 0) return out;
  const PinholeModel& k = frame.intrinsics;
  const int stride = std::max(1, settings_.stride_px);
  // The projector frame's z for a reading at depth z: rotation row 2 and translation, so the
  // whole row's rays are a cheap affine function of depth.
  const Eigen::Matrix3d R = T_projector_camera_.linear();
  const Eigen::Vector3d t = T_projector_camera_ * depth_to_color_m;
  for (int v = 0; v < frame.height; v += stride) {
    for (int u = 0; u < frame.width; u += stride) {
      const std::uint16_t mm = frame.depth_mm[static_cast<std::size_t>(v) * frame.width + u];
      if (mm == 0) continue;
      const double z = 1e-3 * mm;
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const Eigen::Vector3d q = R * (ray * z) + t;
      if (q.z() < settings_.min_range_m || q.z() >= limit_m_) continue;
      if (!in_region({fx_ * q.x() / q.z() + cx_, fy_ * q.y() / q.z() + cy_}, q.z())) continue;
      ++out.points;
      out.nearest_m = std::min(out.nearest_m, q.z());
    }
  }
  out.blocked = out.points >= settings_.min_points;
  return out;
}

}  // namespace projtour::light
