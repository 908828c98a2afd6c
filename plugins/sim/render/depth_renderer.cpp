// One ray per pixel through the scene.
#include "projtour_sim/depth_renderer.hpp"

#include <algorithm>
#include <stdexcept>

namespace projtour::sim {

DepthRenderer::DepthRenderer(const PinholeModel& intrinsics) : intrinsics_(intrinsics) {
  if (intrinsics.width <= 0 || intrinsics.height <= 0 || intrinsics.fx <= 0 || intrinsics.fy <= 0) {
    throw std::invalid_argument("DepthRenderer: intrinsics need a positive size and focal length");
  }
  rays_.resize(static_cast<std::size_t>(intrinsics.width) * intrinsics.height);
  for (int v = 0; v < intrinsics.height; ++v) {
    for (int u = 0; u < intrinsics.width; ++u) {
      rays_[static_cast<std::size_t>(v) * intrinsics.width + u] =
          intrinsics.unproject(Eigen::Vector2d(u, v)).cast<float>();
    }
  }
}

void DepthRenderer::render(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                           IdealDepth& out, double max_depth_m) const {
  const std::size_t n = rays_.size();
  out.width = intrinsics_.width;
  out.height = intrinsics_.height;
  out.depth_m.resize(n);
  out.object_id.resize(n);
  out.cos_incidence.resize(n);
  out.normal.resize(n);
  const Eigen::Matrix3f R = T_world_camera.linear().cast<float>();
  const Eigen::Vector3f origin = T_world_camera.translation().cast<float>();
  const float t_max = static_cast<float>(std::min<double>(max_depth_m, 1e30));
  auto store = [&](std::size_t i, const Eigen::Vector3f& dir, const RayHit& hit) {
    if (hit.object_id != kNoObject) {
      // The ray has unit optical z, so its parameter at the hit is the depth itself.
      const float cos_in = hit.normal.dot(dir) / dir.norm();
      out.depth_m[i] = hit.t;
      out.object_id[i] = hit.object_id;
      out.cos_incidence[i] = std::fabs(cos_in);
      out.normal[i] = cos_in > 0.0f ? Eigen::Vector3f(-hit.normal) : hit.normal;
    } else {
      out.depth_m[i] = 0.0f;
      out.object_id[i] = kNoObject;
      out.cos_incidence[i] = 0.0f;
      out.normal[i].setZero();
    }
  };
  // 2x2 pixel packets inside 8x8 tiles: neighbouring rays walk the same BVH nodes together and
  // the tile keeps those nodes in cache. Odd edges fall back to single rays.
  constexpr int kTile = 8;
  const int w = intrinsics_.width, h = intrinsics_.height;
  RayHit hits[4];
  for (int v0 = 0; v0 < h; v0 += kTile) {
    for (int u0 = 0; u0 < w; u0 += kTile) {
      const int v_end = std::min(v0 + kTile, h), u_end = std::min(u0 + kTile, w);
      for (int v = v0; v < v_end; v += 2) {
        for (int u = u0; u < u_end; u += 2) {
          if (v + 1 < v_end && u + 1 < u_end) {
            const std::size_t idx[4] = {static_cast<std::size_t>(v) * w + u,
                                        static_cast<std::size_t>(v) * w + u + 1,
                                        static_cast<std::size_t>(v + 1) * w + u,
                                        static_cast<std::size_t>(v + 1) * w + u + 1};
            Eigen::Vector3f dirs[4];
            float dx[4], dy[4], dz[4];
            for (int k = 0; k < 4; ++k) {
              dirs[k] = R * rays_[idx[k]];
              dx[k] = dirs[k].x();
              dy[k] = dirs[k].y();
              dz[k] = dirs[k].z();
            }
            scene.intersect4(origin, dx, dy, dz, t_max, hits);
            for (int k = 0; k < 4; ++k) store(idx[k], dirs[k], hits[k]);
          } else {
            for (int vv = v; vv < std::min(v + 2, v_end); ++vv) {
              for (int uu = u; uu < std::min(u + 2, u_end); ++uu) {
                const std::size_t i = static_cast<std::size_t>(vv) * w + uu;
                const Eigen::Vector3f dir = R * rays_[i];
                scene.intersect(origin, dir, t_max, hits[0]);
                store(i, dir, hits[0]);
              }
            }
          }
        }
      }
    }
  }
}

}  // namespace projtour::sim
