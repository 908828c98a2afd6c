#pragma once
// The sphere crop's parts, shared by crop_sphere (which fills its whole window) and the
// registration's scene pyramid (which reads only the parts of the window it needs, pixel for
// pixel the same points).
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "projtour/contract/depth_frame.hpp"

namespace projtour::perception::detail {

// The window of the image bounding a sphere's projection, and the per-pixel test.
struct SphereCrop {
  int u_lo = 0, u_hi = 0, v_lo = 0, v_hi = 0;              // [lo, hi) in full-resolution pixels
  Eigen::Vector3f centre_depth = Eigen::Vector3f::Zero();  // in the depth optical frame
  float r2 = 0.0f;
  float z_min = 0.0f, z_max = 0.0f;
  Eigen::Vector3f depth_to_color_m = Eigen::Vector3f::Zero();
  int width() const { return u_hi - u_lo; }
  int height() const { return v_hi - v_lo; }
};

// Throws std::invalid_argument for a frame whose size or intrinsics do not add up.
void check_frame(const DepthFrame& frame);

// An empty window when the sphere is empty or behind the camera.
SphereCrop sphere_crop(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                       const Eigen::Vector3d& centre_camera, double radius_m);

// A camera's unit-depth rays over a crop's window: per column and per row without distortion
// (a pixel's ray is its column's x and its row's y), from the camera's cached table with it.
class RayTable;
class WindowRays {
 public:
  WindowRays(const DepthFrame& frame, const SphereCrop& crop);
  // Without distortion, the rays' x per column of the window (from its first) and y of row v;
  // nullptr with distortion.
  const float* column_x() const { return table_ != nullptr ? nullptr : column_x_.data(); }
  const float& row_y(int v) const { return row_y_[v - v0_]; }
  // (u, v) in full-resolution pixels inside the window.
  Eigen::Vector2f at(int u, int v) const {
    if (table_ != nullptr) return table_[static_cast<std::size_t>(v) * table_width_ + u];
    return {column_x_[u - u0_], row_y_[v - v0_]};
  }

 private:
  int u0_, v0_;
  std::vector<float> column_x_, row_y_;
  std::shared_ptr<const RayTable> table_owner_;
  const Eigen::Vector2f* table_ = nullptr;
  int table_width_ = 0;
};

// The crop's point (camera frame) for a reading and its pixel's ray; NaN outside the sphere or
// its depth range and where there is no reading.
inline Eigen::Vector3f crop_point(std::uint16_t depth_mm, const Eigen::Vector2f& ray,
                                  const SphereCrop& crop) {
  const float z = depth_mm * 0.001f;
  if (depth_mm == 0 || z < crop.z_min || z > crop.z_max) {
    return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  }
  const Eigen::Vector3f p(ray.x() * z, ray.y() * z, z);
  if ((p - crop.centre_depth).squaredNorm() > crop.r2) {
    return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  }
  return p + crop.depth_to_color_m;
}

// crop_point over pixels [u_lo, u_hi) x [v_lo, v_hi) of the window, into planes x, y, z (row r
// of the block from element r * out_stride); returns how many points are valid.
std::size_t crop_rows(const DepthFrame& frame, const SphereCrop& crop, const WindowRays& rays,
                      int v_lo, int v_hi, int u_lo, int u_hi, float* x, float* y, float* z,
                      std::size_t out_stride);

}  // namespace projtour::perception::detail
