#pragma once
// Test scenes for registration: a z-buffered triangle rasterizer into a DepthFrame, and the
// camera geometry of a robot standing in front of a target.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "projtour/depth_frame.hpp"
#include "projtour/geometry.hpp"
#include "projtour/model.hpp"

namespace projtour::test {

inline PinholeModel kinect_intrinsics() {
  PinholeModel k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 525.0;
  k.cx = 319.5;
  k.cy = 239.5;
  return k;
}

// The camera `distance_m` in front of the model (on its +x side), `height_m` above its origin,
// looking at the origin: optical z toward the model, x to the right, y down.
inline Eigen::Isometry3d T_camera_model_facing(double distance_m, double height_m = 0.0) {
  const Eigen::Vector3d eye(distance_m, 0.0, height_m);
  const Eigen::Vector3d z = (-eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T_model_camera = Eigen::Isometry3d::Identity();
  T_model_camera.linear().col(0) = x;
  T_model_camera.linear().col(1) = y;
  T_model_camera.linear().col(2) = z;
  T_model_camera.translation() = eye;
  return T_model_camera.inverse();
}

// A square floor of half-size `half_m` at height `z_m` of the model frame, under the model.
inline TriangleMesh floor_mesh(double z_m, double half_m) {
  TriangleMesh m;
  const float z = static_cast<float>(z_m), h = static_cast<float>(half_m);
  m.vertices = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

// Renders `mesh` placed at T_depth_mesh into `frame` (keeping the nearest surface), exact
// ray-plane depth per pixel centre.
inline void rasterize(const TriangleMesh& mesh, const Eigen::Isometry3d& T_depth_mesh,
                      DepthFrame& frame, std::vector<float>& z_buffer) {
  const PinholeModel& k = frame.intrinsics;
  std::vector<Eigen::Vector3d> v(mesh.vertices.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = T_depth_mesh * mesh.vertices[i].cast<double>();
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d &a = v[t[0]], &b = v[t[1]], &c = v[t[2]];
    if (a.z() <= 0.05 || b.z() <= 0.05 || c.z() <= 0.05) continue;
    Eigen::Vector2d pa(k.fx * a.x() / a.z() + k.cx, k.fy * a.y() / a.z() + k.cy);
    Eigen::Vector2d pb(k.fx * b.x() / b.z() + k.cx, k.fy * b.y() / b.z() + k.cy);
    Eigen::Vector2d pc(k.fx * c.x() / c.z() + k.cx, k.fy * c.y() / c.z() + k.cy);
    const int u_lo = std::max(0, static_cast<int>(std::ceil(std::min({pa.x(), pb.x(), pc.x()}))));
    const int u_hi =
        std::min(frame.width - 1, static_cast<int>(std::floor(std::max({pa.x(), pb.x(), pc.x()}))));
    const int v_lo = std::max(0, static_cast<int>(std::ceil(std::min({pa.y(), pb.y(), pc.y()}))));
    const int v_hi =
        std::min(frame.height - 1, static_cast<int>(std::floor(std::max({pa.y(), pb.y(), pc.y()}))));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double n_dot_a = n.dot(a);
    auto edge = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, double x, double y) {
      return (q.x() - p.x()) * (y - p.y()) - (q.y() - p.y()) * (x - p.x());
    };
    const double area = edge(pa, pb, pc.x(), pc.y());
    if (std::abs(area) < 1e-12) continue;
    for (int y = v_lo; y <= v_hi; ++y) {
      for (int x = u_lo; x <= u_hi; ++x) {
        const double w0 = edge(pb, pc, x, y) / area, w1 = edge(pc, pa, x, y) / area,
                     w2 = edge(pa, pb, x, y) / area;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const Eigen::Vector3d ray((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
        const double denom = n.dot(ray);
        if (std::abs(denom) < 1e-12) continue;
        const float z = static_cast<float>(n_dot_a / denom);
        float& zb = z_buffer[static_cast<std::size_t>(y) * frame.width + x];
        if (z > 0 && z < zb) zb = z;
      }
    }
  }
}

inline DepthFrame depth_from_z_buffer(const PinholeModel& k, const std::vector<float>& z_buffer,
                                      double noise_scale, unsigned seed) {
  DepthFrame frame;
  frame.intrinsics = k;
  frame.width = k.width;
  frame.height = k.height;
  frame.depth_mm.assign(z_buffer.size(), 0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t i = 0; i < z_buffer.size(); ++i) {
    const double z = z_buffer[i];
    if (!std::isfinite(z) || z > 8.0) continue;
    // Kinect-v1 axial noise: 1.2 mm + 1.9 mm (z - 0.4 m)^2.
    const double sigma_m = (1.2 + 1.9 * (z - 0.4) * (z - 0.4)) * 1e-3;
    frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround((z + noise_scale * sigma_m * gauss(rng)) * 1000.0));
  }
  return frame;
}

// The target mesh (and optionally a floor under it) seen from T_camera_model.
inline DepthFrame render_scene(const TriangleMesh& mesh, const Eigen::Isometry3d& T_camera_model,
                               bool with_floor, double noise_scale, unsigned seed) {
  const PinholeModel k = kinect_intrinsics();
  DepthFrame frame;
  frame.intrinsics = k;
  frame.width = k.width;
  frame.height = k.height;
  std::vector<float> z_buffer(static_cast<std::size_t>(k.width) * k.height,
                              std::numeric_limits<float>::infinity());
  rasterize(mesh, T_camera_model, frame, z_buffer);
  if (with_floor) {
    float z_min = 0;
    for (const auto& p : mesh.vertices) z_min = std::min(z_min, p.z());
    rasterize(floor_mesh(z_min, 0.8), T_camera_model, frame, z_buffer);
  }
  return depth_from_z_buffer(k, z_buffer, noise_scale, seed);
}

// A pose error of exactly `trans_m` and `rot_rad` in random directions, applied to the truth.
inline Eigen::Isometry3d perturb(const Eigen::Isometry3d& T_camera_model, double trans_m,
                                 double rot_rad, std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.linear() = Eigen::AngleAxisd(rot_rad, axis).toRotationMatrix();
  delta.translation() = trans_m * dir;
  // Rotation about the model's own centre, translation in the camera frame.
  Eigen::Isometry3d out = T_camera_model * Eigen::Isometry3d(delta.linear());
  out.translation() += delta.translation();
  return out;
}

}  // namespace projtour::test
