// The simulated colour camera: room light, projector light with shadows, lens and sensor.
#include "projtour_sim/colour_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace projtour::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// A shadow ray's first hit nearer than the point by more than this stops the light: less would
// let float rounding on the lit surface itself (and mesh facets around the point) shadow it.
constexpr double kShadowSlack_m = 0.01;
constexpr double kDisplayGamma = 2.2;
constexpr double kMeteredLevel = 0.18;  // auto exposure: mean signal at mid grey

// Standard normal quantiles at the midpoints of 4096 equally likely bins, rescaled to unit
// variance: 12 random bits make one sample, so a 640x480 frame's 0.9 million noise samples cost
// under 200k engine calls and no transcendental functions. Tails end at 3.5 sigma, which an
// 8-bit image cannot tell from a true Gaussian.
constexpr int kGaussianBits = 12;
const std::array<float, 1 << kGaussianBits>& gaussian_table() {
  static const std::array<float, 1 << kGaussianBits> table = [] {
    std::array<float, 1 << kGaussianBits> t{};
    constexpr int n = 1 << kGaussianBits;
    double sum2 = 0.0;
    std::array<double, n> q{};
    for (int i = 0; i < n; ++i) {
      const double p = (i + 0.5) / n;
      // Bisection on the CDF: monotone and exact enough in 60 steps, whatever p.
      double lo = -10.0, hi = 10.0;
      for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
      }
      q[i] = 0.5 * (lo + hi);
      sum2 += q[i] * q[i];
    }
    const double scale = 1.0 / std::sqrt(sum2 / n);
    for (int i = 0; i < n; ++i) t[i] = static_cast<float>(q[i] * scale);
    return t;
  }();
  return table;
}

// Linear signal in 65536 steps of full scale -> display-encoded 8 bits.
constexpr int kSignalSteps = 65535;
const std::array<std::uint8_t, kSignalSteps + 1>& encode_table() {
  static const std::array<std::uint8_t, kSignalSteps + 1> table = [] {
    std::array<std::uint8_t, kSignalSteps + 1> t{};
    for (int i = 0; i <= kSignalSteps; ++i) {
      const double v = std::pow(static_cast<double>(i) / kSignalSteps, 1.0 / kDisplayGamma);
      t[i] = static_cast<std::uint8_t>(std::lround(255.0 * v));
    }
    return t;
  }();
  return table;
}

bool near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  // A base coasting to rest under its first-order lag never quite stops: 0.1 mm and 1e-5 rad
  // move the image by under a twentieth of a pixel, and such frames must still be lookups.
  return (a.translation() - b.translation()).cwiseAbs().maxCoeff() < 1e-4 &&
         (a.linear() - b.linear()).cwiseAbs().maxCoeff() < 1e-5;
}

}  // namespace

ColourRenderer::ColourRenderer(const PinholeModel& camera, const PinholeModel& projector)
    : depth_(camera), projector_(projector) {
  if (projector.width < 2 || projector.height < 2 || projector.fx <= 0 || projector.fy <= 0) {
    throw std::invalid_argument("ColourRenderer: the projector needs a size and a focal length");
  }
  set_light(light_);
}

void ColourRenderer::set_light(const ColourLight& light) {
  light_ = light;
  const double black = light.projector_contrast > 0.0 ? 1.0 / light.projector_contrast : 0.0;
  for (int k = 0; k < 256; ++k) {
    projector_linear_[k] =
        static_cast<float>(black + (1.0 - black) * std::pow(k / 255.0, kDisplayGamma));
  }
  key_.reset();
}

void ColourRenderer::set_albedo(int object_id, const Albedo& albedo) {
  albedo_[object_id] = albedo;
  key_.reset();
}

void ColourRenderer::set_default_albedo(const Albedo& albedo) {
  default_albedo_ = albedo;
  key_.reset();
}

void ColourRenderer::set_background(const Albedo& albedo) {
  background_ = albedo;
  key_.reset();
}

Albedo ColourRenderer::albedo(int object_id) const {
  const auto it = albedo_.find(object_id);
  return it == albedo_.end() ? default_albedo_ : it->second;
}

bool ColourRenderer::key_matches(std::uint64_t scene_version,
                                 const Eigen::Isometry3d& T_world_camera,
                                 const Eigen::Isometry3d& T_world_projector) const {
  return key_ && key_->scene_version == scene_version &&
         near(key_->T_world_camera, T_world_camera) &&
         near(key_->T_world_projector, T_world_projector);
}

void ColourRenderer::compute_paths(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                                   const Eigen::Isometry3d& T_world_projector) {
  depth_.render(scene, T_world_camera, ideal_);
  const std::vector<Eigen::Vector3f>& rays = depth_.rays();
  const std::size_t n = rays.size();
  paths_.assign(n, PixelPath());

  const Eigen::Matrix3f R_world_camera = T_world_camera.linear().cast<float>();
  const Eigen::Vector3f camera_centre = T_world_camera.translation().cast<float>();
  const Eigen::Isometry3d T_projector_world = T_world_projector.inverse();
  const Eigen::Vector3d projector_centre = T_world_projector.translation();
  const Eigen::Vector3f projector_centre_f = projector_centre.cast<float>();
  const int pw = projector_.width, ph = projector_.height;
  const double intensity_cd =
      light_.lamp_lumens * projector_.fx * projector_.fy / (static_cast<double>(pw) * ph);
  const double vertical_lux = 0.5 * light_.room_lux;
  const Eigen::Vector3f background =
      Eigen::Vector3f(background_[0], background_[1], background_[2]) *
      static_cast<float>(vertical_lux / kPi);

  // Pixels the projector may reach wait in fours for their shadow rays: all leave the
  // projector's centre, and neighbours walk the same BVH nodes.
  std::size_t pending[4];
  int pending_count = 0;
  float dx[4], dy[4], dz[4];
  RayHit hits[4];
  auto cast_shadows = [&]() {
    if (pending_count == 0) return;
    for (int k = pending_count; k < 4; ++k) {
      dx[k] = dx[0];
      dy[k] = dy[0];
      dz[k] = dz[0];
    }
    // Each direction is scaled so that t = 1 falls kShadowSlack_m before its point.
    scene.intersect4(projector_centre_f, dx, dy, dz, 1.0f, hits);
    for (int k = 0; k < pending_count; ++k) {
      if (hits[k].object_id != kNoObject) {
        paths_[pending[k]].tap = -1;
        paths_[pending[k]].gain.setZero();
      }
    }
    pending_count = 0;
  };

  for (std::size_t i = 0; i < n; ++i) {
    PixelPath& path = paths_[i];
    const int object = ideal_.object_id[i];
    if (object == kNoObject) {
      path.ambient = background;
      continue;
    }
    const Albedo a = albedo(object);
    const Eigen::Vector3f albedo_v(a[0], a[1], a[2]);
    const Eigen::Vector3f& normal = ideal_.normal[i];
    path.ambient = albedo_v * static_cast<float>(vertical_lux * (1.0 + normal.z()) / kPi);

    const Eigen::Vector3f point = camera_centre + R_world_camera * (rays[i] * ideal_.depth_m[i]);
    const Eigen::Vector3d point_d = point.cast<double>();
    const auto px = projector_.project(T_projector_world * point_d);
    if (!px || px->x() < -0.5 || px->y() < -0.5 || px->x() > pw - 0.5 || px->y() > ph - 0.5) {
      continue;
    }
    const Eigen::Vector3d to_projector = projector_centre - point_d;
    const double d_m = to_projector.norm();
    const double cos_incidence = normal.cast<double>().dot(to_projector) / d_m;
    if (cos_incidence <= 0.0 || d_m <= kShadowSlack_m) continue;  // lit from behind, or inside
    path.gain = albedo_v * static_cast<float>(intensity_cd * cos_incidence / (d_m * d_m * kPi));
    // Edge half-pixels repeat the edge pixel, so both taps stay inside the frame.
    const double u = std::clamp(px->x(), 0.0, pw - 1.0), v = std::clamp(px->y(), 0.0, ph - 1.0);
    const int x0 = std::min(static_cast<int>(u), pw - 2),
              y0 = std::min(static_cast<int>(v), ph - 2);
    path.tap = (y0 * pw + x0) * 3;
    path.wx = static_cast<float>(u - x0);
    path.wy = static_cast<float>(v - y0);

    const Eigen::Vector3d dir = -to_projector * ((d_m - kShadowSlack_m) / d_m);
    pending[pending_count] = i;
    dx[pending_count] = static_cast<float>(dir.x());
    dy[pending_count] = static_cast<float>(dir.y());
    dz[pending_count] = static_cast<float>(dir.z());
    if (++pending_count == 4) cast_shadows();
  }
  cast_shadows();
}

void ColourRenderer::render(const Scene& scene, std::uint64_t scene_version,
                            const Eigen::Isometry3d& T_world_camera,
                            const Eigen::Isometry3d& T_world_projector, const cv::Mat* shown,
                            cv::Mat& radiance) {
  const bool lit = shown != nullptr && !shown->empty();
  if (lit && (shown->type() != CV_8UC3 || shown->cols != projector_.width ||
              shown->rows != projector_.height)) {
    throw std::invalid_argument("ColourRenderer: the projector frame must be 8-bit BGR, " +
                                std::to_string(projector_.width) + "x" +
                                std::to_string(projector_.height));
  }
  if (!key_matches(scene_version, T_world_camera, T_world_projector)) {
    compute_paths(scene, T_world_camera, T_world_projector);
    key_ = Key{scene_version, T_world_camera, T_world_projector};
    ++geometry_renders_;
  }
  // Taps are offsets into a continuous frame.
  const cv::Mat frame = lit && !shown->isContinuous() ? shown->clone() : (lit ? *shown : cv::Mat());
  const std::uint8_t* data = lit ? frame.ptr<std::uint8_t>(0) : nullptr;
  const std::size_t row = static_cast<std::size_t>(projector_.width) * 3;
  const PinholeModel& k = camera();
  radiance.create(k.height, k.width, CV_32FC3);
  float* out = radiance.ptr<float>(0);
  const float* lin = projector_linear_.data();
  for (std::size_t i = 0; i < paths_.size(); ++i, out += 3) {
    const PixelPath& p = paths_[i];
    Eigen::Vector3f l = p.ambient;
    if (lit && p.tap >= 0) {
      const std::uint8_t* t00 = data + p.tap;
      const std::uint8_t* t10 = t00 + row;
      const float w00 = (1.0f - p.wx) * (1.0f - p.wy), w01 = p.wx * (1.0f - p.wy);
      const float w10 = (1.0f - p.wx) * p.wy, w11 = p.wx * p.wy;
      for (int c = 0; c < 3; ++c) {
        const float s =
            w00 * lin[t00[c]] + w01 * lin[t00[3 + c]] + w10 * lin[t10[c]] + w11 * lin[t10[3 + c]];
        l[c] += p.gain[c] * s;
      }
    }
    out[0] = l[0];
    out[1] = l[1];
    out[2] = l[2];
  }
}

ColourFrame ColourRenderer::expose(const cv::Mat& radiance, double exposure_ms,
                                   std::mt19937_64* rng) const {
  const PinholeModel& k = camera();
  if (radiance.type() != CV_32FC3 || radiance.cols != k.width || radiance.rows != k.height) {
    throw std::invalid_argument("ColourRenderer::expose: not a radiance image of this camera");
  }
  cv::Mat image = radiance;
  if (light_.blur_px > 0.0) {
    // +-3 sigma: OpenCV's own choice for float images is +-4, a third more work for nothing an
    // 8-bit picture can show.
    const int ksize = 2 * static_cast<int>(std::ceil(3.0 * light_.blur_px)) + 1;
    cv::GaussianBlur(radiance, image, cv::Size(ksize, ksize), light_.blur_px, light_.blur_px,
                     cv::BORDER_REPLICATE);
  } else if (!image.isContinuous()) {
    image = image.clone();
  }
  ColourFrame frame;
  frame.intrinsics = k;
  frame.width = k.width;
  frame.height = k.height;
  frame.exposure_ms = exposure_ms;
  const std::size_t n = static_cast<std::size_t>(k.width) * k.height * 3;
  frame.bgr.resize(n);
  const float* in = image.ptr<float>(0);
  const float scale = static_cast<float>(exposure_ms / kFullScaleNitMs);
  const auto& encode = encode_table();
  std::uint8_t* out = frame.bgr.data();
  if (rng == nullptr || light_.noise <= 0.0) {
    for (std::size_t i = 0; i < n; ++i) {
      const float v = std::clamp(in[i] * scale, 0.0f, 1.0f);
      out[i] = encode[static_cast<int>(v * kSignalSteps + 0.5f)];
    }
    return frame;
  }
  // One draw from the caller's engine seeds the frame's own SplitMix64 sequence: a fifth of the
  // cost of drawing every sample from a Mersenne Twister, and as reproducible.
  std::uint64_t state = (*rng)();
  const auto next_bits = [&state]() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  constexpr int kPerDraw = 64 / kGaussianBits;
  constexpr std::uint64_t kMask = (1u << kGaussianBits) - 1;
  const float* gauss = gaussian_table().data();
  const float shot = static_cast<float>(light_.noise * light_.noise / kFullWellElectrons);
  const float read = static_cast<float>(light_.noise * kReadNoise * light_.noise * kReadNoise);
  const auto sample = [&](std::size_t j, float g) {
    float v = in[j] * scale;
    v += std::sqrt(std::max(v, 0.0f) * shot + read) * g;
    v = std::clamp(v, 0.0f, 1.0f);
    out[j] = encode[static_cast<int>(v * kSignalSteps + 0.5f)];
  };
  std::size_t j = 0;
  for (; j + kPerDraw <= n; j += kPerDraw) {
    std::uint64_t bits = next_bits();
    for (int s = 0; s < kPerDraw; ++s, bits >>= kGaussianBits) sample(j + s, gauss[bits & kMask]);
  }
  for (std::uint64_t bits = next_bits(); j < n; ++j, bits >>= kGaussianBits) {
    sample(j, gauss[bits & kMask]);
  }
  return frame;
}

double ColourRenderer::auto_exposure_ms(const cv::Mat& radiance, double min_ms,
                                        double max_ms) const {
  const cv::Scalar mean = cv::mean(radiance);
  const double level = (mean[0] + mean[1] + mean[2]) / 3.0;
  if (!(level > 0.0)) return max_ms;
  return std::clamp(kMeteredLevel * kFullScaleNitMs / level, min_ms, max_ms);
}

}  // namespace projtour::sim
