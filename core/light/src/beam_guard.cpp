// The beam guard (see beam_guard.hpp).
#include "projtour/light/beam_guard.hpp"

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

inline bool BeamGuard::reads_in_beam(const PinholeModel& k, int u, int v, std::uint16_t mm,
                                     const Eigen::Matrix3d& R,
                                     const Eigen::Vector3d& t_projector_colour, double* z_m) const {
  if (mm == 0) return false;
  const double z = 1e-3 * mm;
  const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  const Eigen::Vector3d q = R * (ray * z) + t_projector_colour;
  if (q.z() < settings_.min_range_m || q.z() >= limit_m_) return false;
  if (!in_region({fx_ * q.x() / q.z() + cx_, fy_ * q.y() / q.z() + cy_}, q.z())) return false;
  *z_m = q.z();
  return true;
}

BeamIntrusion BeamGuard::check(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                               std::vector<std::size_t>* in_beam) const {
  BeamIntrusion out;
  if (in_beam != nullptr) in_beam->clear();
  if (!armed_ || frame.width <= 0 || frame.height <= 0) return out;
  const PinholeModel& k = frame.intrinsics;
  const int stride = std::max(1, settings_.stride_px);
  // Hoisted: the guard reads every pixel of every frame while lit (bench_live_loop's beam watch).
  const Eigen::Matrix3d R = T_projector_camera_.linear();
  const Eigen::Vector3d t = T_projector_camera_ * depth_to_color_m;
  for (int v = 0; v < frame.height; v += stride) {
    for (int u = 0; u < frame.width; u += stride) {
      const std::size_t i = static_cast<std::size_t>(v) * frame.width + u;
      double z_m = 0.0;
      if (!reads_in_beam(k, u, v, frame.depth_mm[i], R, t, &z_m)) continue;
      ++out.points;
      out.nearest_m = std::min(out.nearest_m, z_m);
      if (in_beam != nullptr) in_beam->push_back(i);
    }
  }
  out.blocked = out.points >= settings_.min_points;
  return out;
}

std::size_t BeamGuard::seen_clear(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                                  const std::vector<std::size_t>& pixels) const {
  if (!armed_ || frame.width <= 0 || frame.height <= 0) return 0;
  const Eigen::Matrix3d R = T_projector_camera_.linear();
  const Eigen::Vector3d t = T_projector_camera_ * depth_to_color_m;
  std::size_t clear = 0;
  for (const std::size_t i : pixels) {
    if (i >= frame.depth_mm.size() || frame.depth_mm[i] == 0) continue;
    const int u = static_cast<int>(i % frame.width);
    const int v = static_cast<int>(i / frame.width);
    double z_m = 0.0;
    clear += !reads_in_beam(frame.intrinsics, u, v, frame.depth_mm[i], R, t, &z_m);
  }
  return clear;
}

}  // namespace projtour::light
