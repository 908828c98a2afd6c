// Depth frames to organized clouds: whole frame, a crop around a sphere, and frame averaging.
#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "projtour/geometry.hpp"
#include "projtour/registration.hpp"

namespace projtour {

std::size_t OrganizedCloud::valid_count() const {
  return static_cast<std::size_t>(std::count_if(points.begin(), points.end(),
                                                [](const Eigen::Vector3f& p) { return valid(p); }));
}

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

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
  const Eigen::Vector2f& at(int u, int v) const {
    return rays_[static_cast<std::size_t>(v) * width_ + u];
  }

 private:
  bool same_camera(const PinholeModel& k, int width, int height) const {
    return width == width_ && height == height_ && k.fx == k_.fx && k.fy == k_.fy &&
           k.cx == k_.cx && k.cy == k_.cy && k.distortion == k_.distortion;
  }
  PinholeModel k_;
  int width_, height_;
  std::vector<Eigen::Vector2f> rays_;
};

// Turns pixels into unit-depth rays, with the distortion model only when the camera has one
// (then from the camera's RayTable).
class RayMaker {
 public:
  RayMaker(const PinholeModel& k, int width, int height)
      : k_(k),
        table_(k.has_distortion() ? RayTable::of(k, width, height) : nullptr),
        inv_fx_(1.0 / k.fx),
        inv_fy_(1.0 / k.fy) {}
  bool distorted() const { return table_ != nullptr; }
  Eigen::Vector2f ray(int u, int v) const {
    if (table_) return table_->at(u, v);
    return {static_cast<float>((u - k_.cx) * inv_fx_), static_cast<float>((v - k_.cy) * inv_fy_)};
  }

 private:
  const PinholeModel& k_;
  std::shared_ptr<const RayTable> table_;
  double inv_fx_, inv_fy_;
};

void check_frame(const DepthFrame& frame) {
  if (frame.width <= 0 || frame.height <= 0 ||
      frame.depth_mm.size() != static_cast<std::size_t>(frame.width) * frame.height) {
    throw std::invalid_argument("depth frame: size does not match its pixel count");
  }
  if (frame.intrinsics.fx <= 0.0 || frame.intrinsics.fy <= 0.0) {
    throw std::invalid_argument("depth frame: intrinsics without a focal length");
  }
}

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
  check_frame(frame);
  OrganizedCloud cloud = empty_window(frame, depth_to_color_m, 0, 0, frame.width, frame.height);
  const RayMaker rays(frame.intrinsics, frame.width, frame.height);
  const float min_z = static_cast<float>(min_range_m), max_z = static_cast<float>(max_range_m);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const std::uint16_t d = frame.at(u, v);
      const float z = d * 0.001f;
      if (d == 0 || z < min_z || z > max_z) continue;
      const Eigen::Vector2f r = rays.ray(u, v);
      cloud.points[static_cast<std::size_t>(v) * frame.width + u] =
          Eigen::Vector3f(r.x() * z, r.y() * z, z) + cloud.depth_to_color_m;
    }
  }
  return cloud;
}

OrganizedCloud crop_sphere(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                           const Eigen::Vector3d& centre_camera, double radius_m) {
  check_frame(frame);
  const Eigen::Vector3d c = centre_camera - depth_to_color_m;  // in the depth optical frame
  const double r = radius_m;
  if (!(r > 0.0) || c.z() + r <= 0.0) return empty_window(frame, depth_to_color_m, 0, 0, 0, 0);

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
  const int w = std::max(0, u_hi - u_lo), h = std::max(0, v_hi - v_lo);
  OrganizedCloud cloud = empty_window(frame, depth_to_color_m, u_lo, v_lo, w, h);

  const RayMaker rays(frame.intrinsics, frame.width, frame.height);
  const Eigen::Vector3f cf = c.cast<float>();
  const float r2 = static_cast<float>(r * r);
  const float z_min = static_cast<float>(std::max(0.0, z_near)), z_max = static_cast<float>(z_far);
  // Without distortion a pixel's ray is its column's x and its row's y: the window's columns
  // are solved once, not once per pixel (the same floats either way).
  std::vector<float> column_x;
  if (!rays.distorted()) {
    column_x.resize(static_cast<std::size_t>(w));
    for (int i = 0; i < w; ++i) column_x[i] = rays.ray(u_lo + i, v_lo).x();
  }
  for (int j = 0; j < h; ++j) {
    const int v = v_lo + j;
    const std::uint16_t* depth = &frame.depth_mm[static_cast<std::size_t>(v) * frame.width];
    Eigen::Vector3f* out = &cloud.points[static_cast<std::size_t>(j) * w];
    const float row_y = rays.ray(u_lo, v).y();
    for (int i = 0; i < w; ++i) {
      const int u = u_lo + i;
      const float z = depth[u] * 0.001f;
      if (depth[u] == 0 || z < z_min || z > z_max) continue;  // cheap rejection before the ray
      const Eigen::Vector2f ray =
          column_x.empty() ? rays.ray(u, v) : Eigen::Vector2f(column_x[i], row_y);
      const Eigen::Vector3f p(ray.x() * z, ray.y() * z, z);
      if ((p - cf).squaredNorm() <= r2) out[i] = p + cloud.depth_to_color_m;
    }
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

}  // namespace projtour
