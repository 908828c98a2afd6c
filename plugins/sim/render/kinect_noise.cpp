// The Kinect-v1 noise model (see kinect_noise.hpp for the sources and choices).
#include "projtour_sim/kinect_noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"

namespace projtour::sim {
namespace {

// Standard normal draws from 32 random bits: the quantile function tabulated at 4096 equal
// probability steps and interpolated linearly. About ten times cheaper than
// std::normal_distribution, reproducible across standard libraries, and the tails are cut at
// 3.7 sigma, which a depth sensor's noise does not miss.
class GaussianTable {
 public:
  static constexpr int kSteps = 4096;
  GaussianTable() {
    for (int i = 0; i <= kSteps; ++i) {
      const double p =
          std::clamp(static_cast<double>(i) / kSteps, 0.25 / kSteps, 1.0 - 0.25 / kSteps);
      // Bisection on the CDF 0.5 erfc(-z / sqrt 2): done once, exact to float precision.
      double lo = -10.0, hi = 10.0;
      for (int it = 0; it < 80; ++it) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
      }
      quantile_[i] = static_cast<float>(0.5 * (lo + hi));
    }
  }
  float operator()(std::uint32_t bits) const {
    const std::uint32_t i = bits >> 20;  // 12 bits of step
    const float frac = static_cast<float>(bits & 0xFFFFF) * (1.0f / 1048576.0f);
    return quantile_[i] + frac * (quantile_[i + 1] - quantile_[i]);
  }

 private:
  std::array<float, kSteps + 1> quantile_;
};

const GaussianTable& gaussian_table() {
  static const GaussianTable table;
  return table;
}

// 32 random bits at a time, two per engine call, low half first: the order frames have always
// been drawn in, which a seeded run depends on.
class Draws {
 public:
  explicit Draws(std::mt19937_64& rng) : rng_(rng), unit_normal_(gaussian_table()) {}
  std::uint32_t bits() {
    if (!have_half_) bits_ = rng_();
    have_half_ = !have_half_;
    return static_cast<std::uint32_t>(have_half_ ? bits_ : bits_ >> 32);
  }
  float gaussian() { return unit_normal_(bits()); }
  double uniform() { return static_cast<double>(bits()) * 0x1p-32; }  // [0, 1)

 private:
  std::mt19937_64& rng_;
  const GaussianTable& unit_normal_;
  std::uint64_t bits_ = 0;
  bool have_half_ = false;
};

void check_params(const KinectNoiseParams& p) {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("apply_kinect_noise: ") + what);
  };
  if (p.shadows) require(p.emitter_side == 1 || p.emitter_side == -1, "emitter_side is +1 or -1");
  if (p.flying_pixels) {
    require(p.flying_pixel_probability >= 0.0 && p.flying_pixel_probability <= 1.0,
            "flying_pixel_probability is in [0, 1]");
    require(p.flying_pixel_min_jump_m > 0.0, "flying_pixel_min_jump_m is positive");
  }
  if (p.correlated_noise) {
    require(p.correlated_noise_fraction >= 0.0 && p.correlated_noise_fraction <= 1.0,
            "correlated_noise_fraction is in [0, 1]");
    require(p.correlation_window_px >= 1, "correlation_window_px is at least 1");
  }
}

// 1 where the emitter cannot light what the camera sees. In the emitter's view a point moves by
// side * fx b / z from where the camera sees it, so keyed by side * u - fx b / z the points the
// emitter lights come in decreasing key order when the row is walked from the emitter's side;
// a point whose key exceeds the least key already passed is behind a nearer one.
void emitter_shadow_mask(const IdealDepth& ideal, double fx_px, const KinectNoiseParams& params,
                         std::vector<std::uint8_t>& shadowed) {
  shadowed.assign(ideal.depth_m.size(), 0);
  const double fb_px_m = fx_px * params.baseline_m;
  const int side = params.emitter_side;
  const int w = ideal.width;
  for (int v = 0; v < ideal.height; ++v) {
    const std::size_t row = static_cast<std::size_t>(v) * w;
    double least_key = std::numeric_limits<double>::infinity();
    for (int k = 0; k < w; ++k) {
      const int u = side > 0 ? w - 1 - k : k;
      const double z = ideal.depth_m[row + u];
      if (z <= 0.0) continue;  // nothing there to block the light
      const double key = side * u - fb_px_m / z;
      if (key > least_key) {
        shadowed[row + u] = 1;
      } else {
        least_key = key;
      }
    }
  }
}

// A field correlated over window x window pixels: the sum of independent draws over that
// square. Summed over 81 (or even 9) draws any distribution is Gaussian to well within what a
// depth camera shows (central limit), so the draws are uniform bytes, eight per engine call,
// summed exactly in integers: a quarter of the engine calls of Gaussian draws and no table
// look-up. They cover the image grown by window - 1, so border pixels sum as many as the centre;
// each row of them takes whole engine calls. Returns the factor that makes a sum unit-sigma.
double correlated_field(int width, int height, int window_px, std::mt19937_64& rng,
                        std::vector<std::int32_t>& window_sums) {
  window_sums.resize(static_cast<std::size_t>(width) * height);
  const std::size_t padded_width = static_cast<std::size_t>(width + window_px - 1);
  std::vector<std::int32_t> row((padded_width + 7) / 8 * 8);
  // Horizontal sums of the last window_px rows drawn, and their sum down each column.
  std::vector<std::int32_t> row_sums(static_cast<std::size_t>(window_px) * width, 0);
  std::vector<std::int32_t> column_sums(static_cast<std::size_t>(width), 0);
  for (int r = 0; r < height + window_px - 1; ++r) {
    // 2 b - 255 for a uniform byte b: odd integers in [-255, 255], mean 0.
    for (std::size_t k = 0; k < row.size(); k += 8) {
      std::uint64_t bits = rng();
      for (std::size_t b = 0; b < 8; ++b, bits >>= 8) {
        row[k + b] = 2 * static_cast<std::int32_t>(bits & 0xFF) - 255;
      }
    }
    std::int32_t* oldest = &row_sums[static_cast<std::size_t>(r % window_px) * width];
    std::int32_t running = 0;
    for (int k = 0; k < window_px - 1; ++k) running += row[k];
    for (int u = 0; u < width; ++u) {
      running += row[u + window_px - 1];
      column_sums[u] += running - oldest[u];
      oldest[u] = running;
      running -= row[u];
    }
    if (r < window_px - 1) continue;
    std::copy(column_sums.begin(), column_sums.end(),
              window_sums.begin() + static_cast<std::ptrdiff_t>(r - window_px + 1) * width);
  }
  // Each draw has variance (256^2 - 1) / 3; a sum of window^2 of them, window^2 times that.
  return 1.0 / (window_px * std::sqrt((256.0 * 256.0 - 1.0) / 3.0));
}

// Depths of one image row and of the rows above and below (the row itself at the top and
// bottom), for the flying pixels' edge test.
struct RowNeighbours {
  const float* row;
  const float* up;
  const float* down;
  std::size_t start;  // index of the row's first pixel
  std::size_t width;

  RowNeighbours(const IdealDepth& ideal, int v)
      : row(ideal.depth_m.data() + static_cast<std::size_t>(v) * ideal.width),
        up(v > 0 ? row - ideal.width : row),
        down(v + 1 < ideal.height ? row + ideal.width : row),
        start(static_cast<std::size_t>(v) * ideal.width),
        width(static_cast<std::size_t>(ideal.width)) {}

  // Depth of the 4-neighbour across a depth edge (the largest jump beyond min_jump_m), 0 if
  // pixel u is on none. Shadowed neighbours carry no speckle to mix in.
  float edge_neighbour_depth(std::size_t u, float min_jump_m,
                             const std::vector<std::uint8_t>& shadowed) const {
    const float z = row[u];
    const std::size_t left = u > 0 ? u - 1 : u, right = u + 1 < width ? u + 1 : u;
    // Nearly every pixel is on no edge: rule that out first, a neighbour off the image
    // standing in as the pixel itself (a jump of 0).
    const float largest_jump = std::max(std::max(std::abs(row[left] - z), std::abs(row[right] - z)),
                                        std::max(std::abs(up[u] - z), std::abs(down[u] - z)));
    if (largest_jump <= min_jump_m) return 0.0f;
    const float* depths[4] = {row + left, row + right, up + u, down + u};
    float best_jump = min_jump_m, best_z = 0.0f;
    for (const float* n : depths) {
      const float zn = *n;
      const std::size_t j = start + static_cast<std::size_t>(n - row);  // its pixel index
      if (zn <= 0.0f || (!shadowed.empty() && shadowed[j])) continue;
      const float jump = std::abs(zn - z);
      if (jump > best_jump) {
        best_jump = jump;
        best_z = zn;
      }
    }
    return best_z;
  }
};

// What every pixel of a frame shares.
struct FrameNoise {
  const KinectNoiseParams& params;
  float min_cos;
  double bf_px;
  double steps_per_px;
  const std::vector<std::uint8_t>& shadowed;  // empty: shadows off
  // The correlated part's sigma per unit of window sum, in units of sigma(z) (0: none).
  double correlated_per_sum;
  const std::vector<std::int32_t>& window_sums;
  // The white part's share of the published variance.
  double white_share;
};

// The per-pixel model, instantiated with and without the per-pixel artefacts: without, nothing
// is tested for them, so the runs that leave them off (all of them, so far) pay nothing.
template <bool kArtefacts>
void add_noise(const IdealDepth& ideal, const FrameNoise& f, Draws& draws, DepthFrame& frame) {
  const KinectNoiseParams& params = f.params;
  const bool flying = kArtefacts && params.flying_pixels;
  const bool correlated = kArtefacts && f.correlated_per_sum != 0.0;
  const float min_jump_m = static_cast<float>(params.flying_pixel_min_jump_m);
  for (int v = 0; v < ideal.height; ++v) {
    const RowNeighbours neighbours(ideal, v);
    for (int u = 0; u < ideal.width; ++u) {
      const std::size_t i = neighbours.start + u;
      const double z = ideal.depth_m[i];
      if (z < params.min_depth_m || z > params.max_depth_m || ideal.cos_incidence[i] < f.min_cos) {
        continue;
      }
      double z_matched = z;  // what the block matching locks on to, before noise
      if (flying) {
        const float z_edge = neighbours.edge_neighbour_depth(u, min_jump_m, f.shadowed);
        if (z_edge > 0.0f) {
          const double x = draws.uniform();
          if (x < params.flying_pixel_probability) {
            // Given x < p, x / p is uniform on [0, 1): one draw decides and places the pixel.
            const double t = x / params.flying_pixel_probability;
            z_matched = 1.0 / ((1.0 - t) / z + t / z_edge);
          }
        }
      }
      double z_noisy = z_matched;
      if (params.axial_noise) {
        const double sigma = kinect_axial_sigma_m(z_matched);
        const double step = kinect_quantisation_step_m(z_matched, params);
        const double published_var = kArtefacts ? sigma * sigma * f.white_share : sigma * sigma;
        const double gaussian_var = std::max(published_var - step * step / 12.0, 0.0);
        z_noisy += std::sqrt(gaussian_var) * draws.gaussian();
        if (correlated) z_noisy += f.correlated_per_sum * sigma * f.window_sums[i];
      }
      if (params.quantise && z_noisy > 0.0) {
        const double disparity_steps = std::round(f.bf_px / z_noisy * f.steps_per_px);
        if (disparity_steps <= 0.0) continue;
        z_noisy = f.bf_px / (disparity_steps / f.steps_per_px);
      }
      if (z_noisy < params.min_depth_m || z_noisy > params.max_depth_m) continue;
      frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround(z_noisy * 1000.0));
    }
  }
}

}  // namespace

double kinect_axial_sigma_m(double z_m) {
  const double dz = z_m - 0.4;
  return 0.0012 + 0.0019 * dz * dz;
}

double kinect_quantisation_step_m(double z_m, const KinectNoiseParams& params) {
  if (!params.quantise) return 0.0;
  return z_m * z_m * params.disparity_step_px / (params.baseline_m * params.disparity_focal_px);
}

DepthFrame apply_kinect_noise(const IdealDepth& ideal, const PinholeModel& intrinsics,
                              const KinectNoiseParams& params, std::mt19937_64& rng) {
  check_params(params);
  DepthFrame frame;
  frame.intrinsics = intrinsics;
  frame.width = ideal.width;
  frame.height = ideal.height;
  frame.depth_mm.assign(ideal.depth_m.size(), 0);
  Draws draws(rng);

  std::vector<std::uint8_t> shadowed;
  if (params.shadows) emitter_shadow_mask(ideal, intrinsics.fx, params, shadowed);
  const bool correlated = params.axial_noise && params.correlated_noise;
  std::vector<std::int32_t> window_sums;
  const double correlated_fraction = correlated ? params.correlated_noise_fraction : 0.0;
  const double correlated_per_sum =
      correlated
          ? correlated_fraction * correlated_field(ideal.width, ideal.height,
                                                   params.correlation_window_px, rng, window_sums)
          : 0.0;
  const FrameNoise f{params,
                     static_cast<float>(std::cos(deg_to_rad(params.max_incidence_deg))),
                     params.baseline_m * params.disparity_focal_px,
                     1.0 / params.disparity_step_px,
                     shadowed,
                     correlated_per_sum,
                     window_sums,
                     1.0 - correlated_fraction * correlated_fraction};
  if (params.flying_pixels || correlated_per_sum != 0.0) {
    add_noise<true>(ideal, f, draws, frame);
  } else {
    add_noise<false>(ideal, f, draws, frame);
  }
  // After the noise, so that a shadowed pixel has drawn like any other.
  for (std::size_t i = 0; i < shadowed.size(); ++i) {
    if (shadowed[i]) frame.depth_mm[i] = 0;
  }
  return frame;
}

}  // namespace projtour::sim
