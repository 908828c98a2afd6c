// Depth registered into the colour image, and colour pixels lifted to 3-D against it.
#include "projtour/light/registered_depth.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace projtour::light {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void check_depth(const DepthFrame& depth, const PinholeModel& colour) {
  if (depth.width <= 0 || depth.height <= 0 ||
      depth.depth_mm.size() != static_cast<std::size_t>(depth.width) * depth.height) {
    throw std::invalid_argument("register_depth: depth frame size does not match its pixels");
  }
  if (depth.intrinsics.fx <= 0.0 || depth.intrinsics.fy <= 0.0) {
    throw std::invalid_argument("register_depth: depth intrinsics without a focal length");
  }
  if (colour.width <= 0 || colour.height <= 0 || colour.fx <= 0.0 || colour.fy <= 0.0) {
    throw std::invalid_argument("register_depth: colour intrinsics without a size or focal length");
  }
}

// Unit-depth rays of the depth image, row-major; separable (a table per column and per row)
// unless the depth lens has distortion.
class DepthRays {
 public:
  explicit DepthRays(const PinholeModel& k, int width, int height) : width_(width) {
    distorted_ = k.has_distortion();
    if (distorted_) {
      rays_.resize(static_cast<std::size_t>(width) * height);
      for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
          rays_[static_cast<std::size_t>(v) * width + u] =
              k.unproject(Eigen::Vector2d(u, v)).head<2>().cast<float>();
        }
      }
    } else {
      x_.resize(static_cast<std::size_t>(width));
      y_.resize(static_cast<std::size_t>(height));
      for (int u = 0; u < width; ++u) x_[u] = static_cast<float>((u - k.cx) / k.fx);
      for (int v = 0; v < height; ++v) y_[v] = static_cast<float>((v - k.cy) / k.fy);
    }
  }
  Eigen::Vector2f ray(int u, int v) const {
    if (distorted_) return rays_[static_cast<std::size_t>(v) * width_ + u];
    return {x_[u], y_[v]};
  }

 private:
  int width_;
  bool distorted_ = false;
  std::vector<float> x_, y_;
  std::vector<Eigen::Vector2f> rays_;
};

// The colour pixel a point projects to (nearest), by PinholeModel::project's model -- OpenCV's
// radial-tangential distortion -- written out here: the call across the library boundary, with
// its optional and its distortion check, was half of the registration's time.
// (RegisteredDepth.ReadingsLandWherePinholeModelProjectsThem holds the two equal.)
class ColourLens {
 public:
  explicit ColourLens(const PinholeModel& k)
      : fx_(k.fx),
        fy_(k.fy),
        cx_(k.cx),
        cy_(k.cy),
        k1_(k.distortion[0]),
        k2_(k.distortion[1]),
        p1_(k.distortion[2]),
        p2_(k.distortion[3]),
        k3_(k.distortion[4]),
        width_(k.width),
        height_(k.height) {}
  bool pixel(const Eigen::Vector3d& p, int& u, int& v) const {
    if (p.z() <= 0.0) return false;
    const double inverse_z = 1.0 / p.z();
    const double x = p.x() * inverse_z, y = p.y() * inverse_z;
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1_ + r2 * (k2_ + r2 * k3_));
    const double xd = x * radial + 2.0 * p1_ * x * y + p2_ * (r2 + 2.0 * x * x);
    const double yd = y * radial + p1_ * (r2 + 2.0 * y * y) + 2.0 * p2_ * x * y;
    // Rounded to nearest by truncation, once known to be non-negative.
    const double u_half = fx_ * xd + cx_ + 0.5, v_half = fy_ * yd + cy_ + 0.5;
    if (!(u_half >= 0.0 && v_half >= 0.0)) return false;
    u = static_cast<int>(u_half);
    v = static_cast<int>(v_half);
    return u < width_ && v < height_;
  }

 private:
  double fx_, fy_, cx_, cy_, k1_, k2_, p1_, p2_, k3_;
  int width_, height_;
};

// A neighbour this much nearer is another surface, not noise: over 10 sigma of the Kinect's
// depth noise (1.4e-3 z^2) out to its 4 m range.
float occlusion_gap_m(float z_m) {
  return 0.02f + 0.05f * z_m;
}
// Readings behind at least this many of their 8 neighbours are a leak: at the rim of a surface a
// background pixel has at most 3 or 4 foreground neighbours, inside a hole in it 5 or more.
constexpr int kSurroundedBy = 5;
// How far (in standard deviations of the points' spread) lift may extrapolate its plane.
constexpr double kMaxSupport = 1.5;

}  // namespace

RegisteredDepth register_depth(const DepthFrame& depth, const Eigen::Vector3d& depth_to_color_m,
                               const PinholeModel& colour) {
  check_depth(depth, colour);
  const int w = colour.width, h = colour.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  RegisteredDepth out;
  out.colour = colour;
  out.points_camera.assign(n, Eigen::Vector3f::Constant(kNaN));
  // Depths with a frame of empty pixels around the image, so that every pixel has 8 neighbours.
  const int padded_w = w + 2;
  std::vector<float> z(static_cast<std::size_t>(padded_w) * (h + 2), 0.0f);
  const auto padded = [padded_w](int u, int v) {
    return static_cast<std::size_t>(v + 1) * padded_w + static_cast<std::size_t>(u + 1);
  };

  // Pass 1, the z-buffer: per colour pixel the nearest reading that projects onto it.
  const DepthRays rays(depth.intrinsics, depth.width, depth.height);
  const ColourLens lens(colour);
  const Eigen::Vector3f offset = depth_to_color_m.cast<float>();
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.depth_mm.data() + static_cast<std::size_t>(v) * depth.width;
    for (int u = 0; u < depth.width; ++u) {
      if (row[u] == 0) continue;
      const float d = row[u] * 0.001f;
      const Eigen::Vector2f r = rays.ray(u, v);
      const Eigen::Vector3f p(r.x() * d + offset.x(), r.y() * d + offset.y(), d + offset.z());
      int cu, cv;
      if (!lens.pixel(p.cast<double>(), cu, cv)) continue;
      float& nearest = z[padded(cu, cv)];
      if (nearest == 0.0f || p.z() < nearest) {
        nearest = p.z();
        out.points_camera[static_cast<std::size_t>(cv) * w + cu] = p;
      }
    }
  }

  // Pass 2: holes take the nearest neighbouring reading, and a reading well behind most of its
  // neighbours -- the background that the depth camera sees through a hole in the foreground's
  // coverage, where the colour camera sees the foreground -- gives way to the nearest of them.
  // Both are rare, so the pixels to change are flagged first by a branch-free pass over pass
  // 1's depths, then changed, from pass 1's values only (the order cannot matter).
  std::vector<std::size_t> changed;  // padded indices
  std::vector<std::uint8_t> flag(static_cast<std::size_t>(w));
  for (int v = 0; v < h; ++v) {
    const float* up = z.data() + padded(0, v - 1);
    const float* mid = z.data() + padded(0, v);
    const float* down = z.data() + padded(0, v + 1);
    // Written out so that the compiler vectorises it.
    for (int u = 0; u < w; ++u) {
      const float zi = mid[u];
      const float behind = zi - occlusion_gap_m(zi);
      const float a = up[u - 1], b = up[u], c = up[u + 1], d = mid[u - 1];
      const float e = mid[u + 1], f = down[u - 1], g = down[u], k = down[u + 1];
      const int readings = (a > 0.0f) + (b > 0.0f) + (c > 0.0f) + (d > 0.0f) + (e > 0.0f) +
                           (f > 0.0f) + (g > 0.0f) + (k > 0.0f);
      const int in_front = ((a > 0.0f) & (a < behind)) + ((b > 0.0f) & (b < behind)) +
                           ((c > 0.0f) & (c < behind)) + ((d > 0.0f) & (d < behind)) +
                           ((e > 0.0f) & (e < behind)) + ((f > 0.0f) & (f < behind)) +
                           ((g > 0.0f) & (g < behind)) + ((k > 0.0f) & (k < behind));
      flag[static_cast<std::size_t>(u)] =
          static_cast<std::uint8_t>(zi == 0.0f ? readings > 0 : in_front >= kSurroundedBy);
    }
    for (int u = 0; u < w; ++u) {
      if (flag[static_cast<std::size_t>(u)]) changed.push_back(padded(u, v));
    }
  }
  const std::ptrdiff_t stride = padded_w;
  const std::ptrdiff_t around[8] = {-stride - 1, -stride,    -stride + 1, -1,
                                    1,           stride - 1, stride,      stride + 1};
  const auto unpadded = [padded_w, w](std::size_t i) {
    return (i / padded_w - 1) * static_cast<std::size_t>(w) + (i % padded_w - 1);
  };
  std::vector<std::size_t> source(changed.size());
  for (std::size_t k = 0; k < changed.size(); ++k) {
    const std::size_t i = changed[k];
    std::size_t nearest = i;
    for (const std::ptrdiff_t d : around) {
      const std::size_t j = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(i) + d);
      if (z[j] > 0.0f && (nearest == i || z[j] < z[nearest])) nearest = j;
    }
    source[k] = nearest;
  }

  out.z_m.resize(n);
  for (int v = 0; v < h; ++v) {
    std::copy_n(z.data() + padded(0, v), w, out.z_m.data() + static_cast<std::size_t>(v) * w);
  }
  // Every source is read before any pixel changes.
  std::vector<Eigen::Vector3f> point_from(changed.size());
  for (std::size_t k = 0; k < changed.size(); ++k) {
    point_from[k] = out.points_camera[unpadded(source[k])];
  }
  for (std::size_t k = 0; k < changed.size(); ++k) {
    const std::size_t i = unpadded(changed[k]);
    out.z_m[i] = z[source[k]];
    out.points_camera[i] = point_from[k];
  }
  return out;
}

std::optional<Eigen::Vector3d> lift(const RegisteredDepth& depth, const Eigen::Vector2d& colour_px,
                                    int window_px, double max_spread_m, double max_view_angle_deg) {
  const PinholeModel& k = depth.colour;
  const std::size_t n = static_cast<std::size_t>(k.width) * k.height;
  if (depth.z_m.size() != n || depth.points_camera.size() != n) return std::nullopt;
  if (!k.in_image(colour_px)) return std::nullopt;
  window_px = std::max(window_px, 1);
  const int cu = static_cast<int>(std::lround(colour_px.x()));
  const int cv = static_cast<int>(std::lround(colour_px.y()));
  const int u0 = std::max(cu - window_px, 0), u1 = std::min(cu + window_px, k.width - 1);
  const int v0 = std::max(cv - window_px, 0), v1 = std::min(cv + window_px, k.height - 1);

  // A filled hole repeats its neighbour's reading, which then weighs twice: harmless for a plane.
  std::vector<Eigen::Vector3f> points;
  points.reserve(static_cast<std::size_t>((u1 - u0 + 1) * (v1 - v0 + 1)));
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * k.width + u;
      if (depth.z_m[i] != 0.0f) points.push_back(depth.points_camera[i]);
    }
  }
  const std::size_t window_area =
      static_cast<std::size_t>((2 * window_px + 1) * (2 * window_px + 1));
  const std::size_t min_points = std::max<std::size_t>(6, window_area / 4);
  if (points.size() < min_points) return std::nullopt;

  // Another surface in the window (the wall behind a sign's rim) is far from the depth of the
  // surface the pixel itself sees: the median of the readings next to it. Without any, what the
  // pixel sees is unknown (the depth camera's shadow beside a rim).
  std::vector<float> zs;
  for (int v = std::max(cv - 1, 0); v <= std::min(cv + 1, k.height - 1); ++v) {
    for (int u = std::max(cu - 1, 0); u <= std::min(cu + 1, k.width - 1); ++u) {
      const float z = depth.z_m[static_cast<std::size_t>(v) * k.width + u];
      if (z != 0.0f) zs.push_back(z);
    }
  }
  if (zs.empty()) return std::nullopt;
  std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
  const float reference_z = zs[zs.size() / 2];
  const float gate = static_cast<float>(max_spread_m);
  points.erase(std::remove_if(
                   points.begin(), points.end(),
                   [&](const Eigen::Vector3f& p) { return std::abs(p.z() - reference_z) > gate; }),
               points.end());

  // z = a x + b y + c by least squares about the centroid (the Kinect's error is along depth);
  // a second pass without the points beyond 2.5 RMS.
  Eigen::Vector3d plane = Eigen::Vector3d::Zero();  // a, b, c
  double rms = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (int pass = 0; pass < 2; ++pass) {
    if (points.size() < min_points) return std::nullopt;
    centroid.setZero();
    for (const Eigen::Vector3f& p : points) centroid += p.cast<double>();
    centroid /= static_cast<double>(points.size());
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (const Eigen::Vector3f& p : points) {
      const Eigen::Vector3d d = p.cast<double>() - centroid;
      A += d.head<2>() * d.head<2>().transpose();
      b += d.head<2>() * d.z();
    }
    scatter = A / static_cast<double>(points.size());
    const Eigen::LDLT<Eigen::Matrix2d> solver(A);
    if (solver.info() != Eigen::Success || solver.rcond() < 1e-9) return std::nullopt;
    const Eigen::Vector2d slope = solver.solve(b);
    plane = Eigen::Vector3d(slope.x(), slope.y(), centroid.z() - slope.dot(centroid.head<2>()));
    const auto residual = [&](const Eigen::Vector3f& p) {
      return p.z() - (plane.x() * p.x() + plane.y() * p.y() + plane.z());
    };
    double sum = 0.0;
    for (const Eigen::Vector3f& p : points) sum += residual(p) * residual(p);
    rms = std::sqrt(sum / static_cast<double>(points.size()));
    if (pass == 1 || rms == 0.0) break;
    const double limit = 2.5 * rms;
    points.erase(
        std::remove_if(points.begin(), points.end(),
                       [&](const Eigen::Vector3f& p) { return std::abs(residual(p)) > limit; }),
        points.end());
  }
  if (rms > max_spread_m) return std::nullopt;

  // The ray t * (x, y, 1) meets z = a x + b y + c at t = c / (1 - a x - b y).
  const Eigen::Vector3d ray = k.unproject(colour_px);
  const double denominator = 1.0 - plane.x() * ray.x() - plane.y() * ray.y();
  if (std::abs(denominator) < 1e-6) return std::nullopt;
  const double t = plane.z() / denominator;
  if (!(t > 0.0)) return std::nullopt;
  // The plane holds only over its points: with them all to one side of the ray (a thin band
  // along a rim) the slope across the band is noise, and extrapolating it lands between the
  // surfaces. The ray must pass within kMaxSupport standard deviations of the points' spread.
  const Eigen::Vector2d offset = t * ray.head<2>() - centroid.head<2>();
  const Eigen::LDLT<Eigen::Matrix2d> spread(scatter);
  if (offset.dot(spread.solve(offset)) > kMaxSupport * kMaxSupport) return std::nullopt;
  const double cos_view =
      std::abs(plane.x() * ray.x() + plane.y() * ray.y() - 1.0) /
      (std::sqrt(plane.x() * plane.x() + plane.y() * plane.y() + 1.0) * ray.norm());
  if (cos_view < std::cos(max_view_angle_deg * 3.14159265358979 / 180.0)) return std::nullopt;
  return Eigen::Vector3d(t * ray);
}

}  // namespace projtour::light
