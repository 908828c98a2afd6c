// Depth frames to organized clouds: whole frame, a crop around a sphere, and frame averaging.
#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "crop_internal.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/perception/registration.hpp"
#include "vector_clones.hpp"

namespace projtour::perception {

std::size_t OrganizedCloud::valid_count() const {
  return static_cast<std::size_t>(std::count_if(points.begin(), points.end(),
                                                [](const Eigen::Vector3f& p) { return valid(p); }));
}

namespace detail {

// A camera's unit-depth rays, one per pixel, solved once: undistorting a pixel is an iterative
// solve, and a camera's rays are the same in every frame. Kept per camera (its intrinsics and
// image size) for the process; a handful of cameras at most, so the oldest goes past eight.
class RayTable {
 public:
  static std::shared_ptr<const RayTable> of(const PinholeModel& k, int width, int height) {
    static std::mutex mutex;
    static std::vector<std::shared_ptr<const RayTable>> tables;
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& t : tables) {
      if (t->same_camera(k, width, height)) return t;
    }
    auto made = std::make_shared<const RayTable>(k, width, height);
    if (tables.size() >= 8) tables.erase(tables.begin());
    tables.push_back(made);
    return made;
  }
  RayTable(const PinholeModel& k, int width, int height) : k_(k), width_(width), height_(height) {
    rays_.resize(static_cast<std::size_t>(width) * height);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        rays_[static_cast<std::size_t>(v) * width + u] =
            k.unproject(Eigen::Vector2d(u, v)).head<2>().cast<float>();
      }
    }
  }
  const Eigen::Vector2f* data() const { return rays_.data(); }

 private:
  bool same_camera(const PinholeModel& k, int width, int height) const {
    return width == width_ && height == height_ && k.fx == k_.fx && k.fy == k_.fy &&
           k.cx == k_.cx && k.cy == k_.cy && k.distortion == k_.distortion;
  }
  PinholeModel k_;
  int width_, height_;
  std::vector<Eigen::Vector2f> rays_;
};

WindowRays::WindowRays(const DepthFrame& frame, const SphereCrop& crop)
    : u0_(crop.u_lo), v0_(crop.v_lo) {
  const PinholeModel& k = frame.intrinsics;
  if (k.has_distortion()) {
    table_owner_ = RayTable::of(k, frame.width, frame.height);
    table_ = table_owner_->data();
    table_width_ = frame.width;
    return;
  }
  const double inv_fx = 1.0 / k.fx, inv_fy = 1.0 / k.fy;
  column_x_.resize(static_cast<std::size_t>(std::max(0, crop.width())));
  row_y_.resize(static_cast<std::size_t>(std::max(0, crop.height())));
  for (std::size_t i = 0; i < column_x_.size(); ++i) {
    column_x_[i] = static_cast<float>((crop.u_lo + static_cast<int>(i) - k.cx) * inv_fx);
  }
  for (std::size_t j = 0; j < row_y_.size(); ++j) {
    row_y_[j] = static_cast<float>((crop.v_lo + static_cast<int>(j) - k.cy) * inv_fy);
  }
}

void check_frame(const DepthFrame& frame) {
  if (frame.width <= 0 || frame.height <= 0 ||
      frame.depth_mm.size() != static_cast<std::size_t>(frame.width) * frame.height) {
    throw std::invalid_argument("depth frame: size does not match its pixel count");
  }
  if (frame.intrinsics.fx <= 0.0 || frame.intrinsics.fy <= 0.0) {
    throw std::invalid_argument("depth frame: intrinsics without a focal length");
  }
}

SphereCrop sphere_crop(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                       const Eigen::Vector3d& centre_camera, double radius_m) {
  SphereCrop crop;
  crop.depth_to_color_m = depth_to_color_m.cast<float>();
  const Eigen::Vector3d c = centre_camera - depth_to_color_m;  // in the depth optical frame
  const double r = radius_m;
  if (!(r > 0.0) || c.z() + r <= 0.0) return crop;

  // The window: the bounding box of the sphere's image. Along each image axis the extremes of
  // x/z (y/z) are the tangents from the camera to the sphere's disc in the xz (yz) plane; the
  // whole image when the camera is inside or beside the sphere.
  int u_lo = 0, u_hi = frame.width, v_lo = 0, v_hi = frame.height;
  const PinholeModel& k = frame.intrinsics;
  const double z_near = c.z() - r, z_far = c.z() + r;
  const auto tangents = [r](double a, double z, double& lo, double& hi) {
    const double d = std::hypot(a, z);
    if (d <= r * 1.0001) return false;
    const double centre = std::atan2(a, z), half = std::asin(r / d);
    if (centre - half <= -kPi / 2 + 1e-3 || centre + half >= kPi / 2 - 1e-3) return false;
    lo = std::tan(centre - half), hi = std::tan(centre + half);
    return true;
  };
  double xl, xh, yl, yh;
  if (z_near > 1e-3 && tangents(c.x(), c.z(), xl, xh) && tangents(c.y(), c.z(), yl, yh)) {
    double pu_lo = k.fx * xl + k.cx, pu_hi = k.fx * xh + k.cx;
    double pv_lo = k.fy * yl + k.cy, pv_hi = k.fy * yh + k.cy;
    if (k.has_distortion()) {
      // Distortion moves the box's corners; take the hull of the distorted corners with slack.
      pu_lo = pv_lo = 1e9;
      pu_hi = pv_hi = -1e9;
      for (double x : {xl, xh}) {
        for (double y : {yl, yh}) {
          const auto px = k.project(Eigen::Vector3d(x, y, 1.0));
          pu_lo = std::min(pu_lo, px->x()), pu_hi = std::max(pu_hi, px->x());
          pv_lo = std::min(pv_lo, px->y()), pv_hi = std::max(pv_hi, px->y());
        }
      }
      pu_lo -= 8, pv_lo -= 8, pu_hi += 8, pv_hi += 8;
    }
    u_lo = std::clamp(static_cast<int>(std::floor(pu_lo)), 0, frame.width);
    u_hi = std::clamp(static_cast<int>(std::ceil(pu_hi)) + 1, 0, frame.width);
    v_lo = std::clamp(static_cast<int>(std::floor(pv_lo)), 0, frame.height);
    v_hi = std::clamp(static_cast<int>(std::ceil(pv_hi)) + 1, 0, frame.height);
  }
  crop.u_lo = u_lo;
  crop.v_lo = v_lo;
  crop.u_hi = std::max(u_lo, u_hi);
  crop.v_hi = std::max(v_lo, v_hi);
  crop.centre_depth = c.cast<float>();
  crop.r2 = static_cast<float>(r * r);
  crop.z_min = static_cast<float>(std::max(0.0, z_near));
  crop.z_max = static_cast<float>(z_far);
  return crop;
}

namespace {

// crop_point without distortion, on its own so that the planes are known not to overlap and the
// compiler turns it into vector instructions.
// One row of crop_point for a pinhole camera; kWidth > 0 fixes the row's length at compile
// time (a whole tile), so the vector loop has no remainder to peel.
template <int kWidth>
inline int crop_row_pinhole(std::size_t n, const std::uint16_t* __restrict__ depth,
                            const float* __restrict__ ray_x, float ray_y, const SphereCrop& crop,
                            float* __restrict__ x, float* __restrict__ y, float* __restrict__ z) {
  if constexpr (kWidth > 0) n = kWidth;
  const float c0 = crop.centre_depth.x(), c1 = crop.centre_depth.y(), c2 = crop.centre_depth.z();
  const float o0 = crop.depth_to_color_m.x(), o1 = crop.depth_to_color_m.y(),
              o2 = crop.depth_to_color_m.z();
  const float z_min = crop.z_min, z_max = crop.z_max, r2 = crop.r2;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  int valid = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const float d = depth[k] * 0.001f;
    const float px = ray_x[k] * d, py = ray_y * d;
    const float ex = px - c0, ey = py - c1, ez = d - c2;
    const bool in =
        (depth[k] != 0) & (d >= z_min) & (d <= z_max) & (ex * ex + ey * ey + ez * ez <= r2);
    // Computed for every pixel and then chosen, so the loop has no branch to vectorize around.
    const float qx = px + o0, qy = py + o1, qz = d + o2;
    x[k] = in ? qx : nan;
    y[k] = in ? qy : nan;
    z[k] = in ? qz : nan;
    valid += in;
  }
  return valid;
}

// crop_rows for a pinhole camera: the rows in one call, so a tile's sixteen short rows pay for
// the call and the setup once.
PROJTOUR_VECTOR_CLONES std::size_t crop_rows_pinhole(int rows, std::size_t n,
                                                     const std::uint16_t* depth,
                                                     std::size_t depth_stride, const float* ray_x,
                                                     const float* ray_y, const SphereCrop& crop,
                                                     float* x, float* y, float* z,
                                                     std::size_t out_stride) {
  std::size_t valid = 0;
  for (int r = 0; r < rows; ++r) {
    const std::size_t in = static_cast<std::size_t>(r) * depth_stride;
    const std::size_t out = static_cast<std::size_t>(r) * out_stride;
    valid += static_cast<std::size_t>(
        n == 16
            ? crop_row_pinhole<16>(n, depth + in, ray_x, ray_y[r], crop, x + out, y + out, z + out)
            : crop_row_pinhole<0>(n, depth + in, ray_x, ray_y[r], crop, x + out, y + out, z + out));
  }
  return valid;
}

}  // namespace

std::size_t crop_rows(const DepthFrame& frame, const SphereCrop& crop, const WindowRays& rays,
                      int v_lo, int v_hi, int u_lo, int u_hi, float* x, float* y, float* z,
                      std::size_t out_stride) {
  if (v_lo >= v_hi || u_lo >= u_hi) return 0;
  const std::uint16_t* depth = &frame.depth_mm[static_cast<std::size_t>(v_lo) * frame.width];
  if (rays.column_x() != nullptr) {
    return crop_rows_pinhole(v_hi - v_lo, static_cast<std::size_t>(u_hi - u_lo), depth + u_lo,
                             static_cast<std::size_t>(frame.width),
                             rays.column_x() + (u_lo - crop.u_lo), &rays.row_y(v_lo), crop, x, y, z,
                             out_stride);
  }
  std::size_t valid = 0;
  for (int v = v_lo; v < v_hi; ++v) {
    const std::size_t row = static_cast<std::size_t>(v - v_lo) * out_stride;
    for (int u = u_lo; u < u_hi; ++u) {
      const Eigen::Vector3f p =
          crop_point(depth[(v - v_lo) * frame.width + u], rays.at(u, v), crop);
      const std::size_t k = row + static_cast<std::size_t>(u - u_lo);
      x[k] = p.x(), y[k] = p.y(), z[k] = p.z();
      valid += p.z() == p.z();
    }
  }
  return valid;
}

}  // namespace detail

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

OrganizedCloud empty_window(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                            int u0, int v0, int width, int height) {
  OrganizedCloud cloud;
  cloud.intrinsics = frame.intrinsics;
  cloud.intrinsics.width = frame.width;
  cloud.intrinsics.height = frame.height;
  cloud.depth_to_color_m = depth_to_color_m.cast<float>();
  cloud.u0 = u0;
  cloud.v0 = v0;
  cloud.width = width;
  cloud.height = height;
  cloud.points.assign(static_cast<std::size_t>(width) * height, Eigen::Vector3f::Constant(kNaN));
  return cloud;
}

}  // namespace

OrganizedCloud organized_cloud(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                               double min_range_m, double max_range_m) {
  detail::check_frame(frame);
  OrganizedCloud cloud = empty_window(frame, depth_to_color_m, 0, 0, frame.width, frame.height);
  detail::SphereCrop whole;
  whole.u_hi = frame.width;
  whole.v_hi = frame.height;
  const detail::WindowRays rays(frame, whole);
  const float min_z = static_cast<float>(min_range_m), max_z = static_cast<float>(max_range_m);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const std::uint16_t d = frame.at(u, v);
      const float z = d * 0.001f;
      if (d == 0 || z < min_z || z > max_z) continue;
      const Eigen::Vector2f r = rays.at(u, v);
      cloud.points[static_cast<std::size_t>(v) * frame.width + u] =
          Eigen::Vector3f(r.x() * z, r.y() * z, z) + cloud.depth_to_color_m;
    }
  }
  return cloud;
}

OrganizedCloud crop_sphere(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                           const Eigen::Vector3d& centre_camera, double radius_m) {
  detail::check_frame(frame);
  const detail::SphereCrop crop =
      detail::sphere_crop(frame, depth_to_color_m, centre_camera, radius_m);
  const int w = crop.width(), h = crop.height();
  OrganizedCloud cloud = empty_window(frame, depth_to_color_m, crop.u_lo, crop.v_lo, w, h);
  if (w == 0 || h == 0) return cloud;
  // Row by row through the planes registration reads, so both crop the same points.
  const detail::WindowRays rays(frame, crop);
  std::vector<float> planes(3 * static_cast<std::size_t>(w));
  for (int j = 0; j < h; ++j) {
    detail::crop_rows(frame, crop, rays, crop.v_lo + j, crop.v_lo + j + 1, crop.u_lo, crop.u_hi,
                      planes.data(), planes.data() + w, planes.data() + 2 * w, 0);
    Eigen::Vector3f* out = &cloud.points[static_cast<std::size_t>(j) * w];
    for (int i = 0; i < w; ++i) out[i] = {planes[i], planes[w + i], planes[2 * w + i]};
  }
  return cloud;
}

DepthFrame average_depth_frames(const std::vector<DepthFrame>& frames) {
  if (frames.empty()) throw std::invalid_argument("average_depth_frames: no frames");
  const DepthFrame& first = frames.front();
  for (const DepthFrame& f : frames) {
    if (f.width != first.width || f.height != first.height ||
        f.depth_mm.size() != first.depth_mm.size()) {
      throw std::invalid_argument("average_depth_frames: frames of different sizes");
    }
  }
  DepthFrame out = frames.back();
  if (frames.size() == 1) return out;
  const std::size_t needed = (frames.size() + 1) / 2;
  std::vector<std::uint16_t> readings;
  readings.reserve(frames.size());
  for (std::size_t p = 0; p < out.depth_mm.size(); ++p) {
    readings.clear();
    for (const DepthFrame& f : frames) {
      if (f.depth_mm[p] != 0) readings.push_back(f.depth_mm[p]);
    }
    if (readings.size() < needed) {
      out.depth_mm[p] = 0;
      continue;
    }
    std::nth_element(readings.begin(), readings.begin() + readings.size() / 2, readings.end());
    const double median = readings[readings.size() / 2];
    double sum = 0.0;
    int count = 0;
    for (std::uint16_t d : readings) {
      if (std::abs(d - median) <= 0.03 * median) sum += d, ++count;
    }
    out.depth_mm[p] = static_cast<std::uint16_t>(std::lround(sum / count));
  }
  return out;
}

}  // namespace projtour::perception
