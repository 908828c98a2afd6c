#pragma once
// The scene pyramid the alignment reads: levels of the depth image's window, built in tiles on
// first use.
// Included only by registration_icp.cpp, the one translation unit of the alignment: its
// types stay in that unit's anonymous namespace, so the hot loop inlines (and the compiler
// sees every call of each helper) exactly as when it was one file.
#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "crop_internal.hpp"
#include "icp_scratch.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::perception {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// A pyramid level's planes hold this many floats past their last pixel, so the nearest-point
// search may read a row's last group of four past the window's right edge (those lanes are
// masked before they count).
#if defined(__SSE2__)
constexpr std::size_t kPlanePad = 4;
#else
constexpr std::size_t kPlanePad = 0;
#endif

// downsample (below) for blocks [k0, n) whose children all lie in the finer window: rows r0
// and r1 of the finer planes from the blocks' first child. Branch-free: the children's sums skip
// those out of the nearest's depth band by adding zero, which leaves the sums as downsample's.
void downsample_blocks(std::size_t k0, std::size_t n, const float* __restrict__ x0,
                       const float* __restrict__ y0, const float* __restrict__ z0,
                       const float* __restrict__ x1, const float* __restrict__ y1,
                       const float* __restrict__ z1, float* __restrict__ x, float* __restrict__ y,
                       float* __restrict__ z) {
  const float inf = std::numeric_limits<float>::infinity();
  for (std::size_t k = k0; k < n; ++k) {
    const float za = z0[2 * k], zb = z0[2 * k + 1], zc = z1[2 * k], zd = z1[2 * k + 1];
    // NaN compares false: a missing child is never the nearest, nor taken.
    float z_min = za < inf ? za : inf;
    z_min = zb < z_min ? zb : z_min;
    z_min = zc < z_min ? zc : z_min;
    z_min = zd < z_min ? zd : z_min;
    const float z_max = z_min * 1.02f;
    const bool ta = za <= z_max, tb = zb <= z_max, tc = zc <= z_max, td = zd <= z_max;
    // Loaded whether taken or not: a load under a condition would keep the loop's branches.
    const float xa = x0[2 * k], xb = x0[2 * k + 1], xc = x1[2 * k], xd = x1[2 * k + 1];
    const float ya = y0[2 * k], yb = y0[2 * k + 1], yc = y1[2 * k], yd = y1[2 * k + 1];
    const float sx =
        (((0.0f + (ta ? xa : 0.0f)) + (tb ? xb : 0.0f)) + (tc ? xc : 0.0f)) + (td ? xd : 0.0f);
    const float sy =
        (((0.0f + (ta ? ya : 0.0f)) + (tb ? yb : 0.0f)) + (tc ? yc : 0.0f)) + (td ? yd : 0.0f);
    const float sz =
        (((0.0f + (ta ? za : 0.0f)) + (tb ? zb : 0.0f)) + (tc ? zc : 0.0f)) + (td ? zd : 0.0f);
    const float count =
        (ta ? 1.0f : 0.0f) + (tb ? 1.0f : 0.0f) + (tc ? 1.0f : 0.0f) + (td ? 1.0f : 0.0f);
    const float mx = sx / count, my = sy / count, mz = sz / count;
    const bool any = count > 0.0f;
    x[k] = any ? mx : kNaN;
    y[k] = any ? my : kNaN;
    z[k] = any ? mz : kNaN;
  }
}

#if defined(__SSE2__)
// Four blocks at a time in SSE2, the same operations in the same order as downsample_blocks
// (GCC does not vectorize that loop by itself: its strided loads keep it from if-converting).
void downsample_row(std::size_t n, const float* x0, const float* y0, const float* z0,
                    const float* x1, const float* y1, const float* z1, float* x, float* y,
                    float* z) {
  const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
  const __m128 band = _mm_set1_ps(1.02f), one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
  const __m128 nan = _mm_set1_ps(kNaN);
  // Even and odd children of four blocks from eight consecutive floats.
  const auto split = [](const float* p, __m128& even, __m128& odd) {
    const __m128 lo = _mm_loadu_ps(p), hi = _mm_loadu_ps(p + 4);
    even = _mm_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0));
    odd = _mm_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1));
  };
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    __m128 za, zb, zc, zd, xa, xb, xc, xd, ya, yb, yc, yd;
    split(z0 + 2 * k, za, zb);
    split(z1 + 2 * k, zc, zd);
    split(x0 + 2 * k, xa, xb);
    split(x1 + 2 * k, xc, xd);
    split(y0 + 2 * k, ya, yb);
    split(y1 + 2 * k, yc, yd);
    // _mm_min_ps(a, b) is a < b ? a : b: a NaN child leaves the minimum as it was.
    __m128 z_min = _mm_min_ps(za, inf);
    z_min = _mm_min_ps(zb, z_min);
    z_min = _mm_min_ps(zc, z_min);
    z_min = _mm_min_ps(zd, z_min);
    const __m128 z_max = _mm_mul_ps(z_min, band);
    const __m128 ta = _mm_cmple_ps(za, z_max), tb = _mm_cmple_ps(zb, z_max);
    const __m128 tc = _mm_cmple_ps(zc, z_max), td = _mm_cmple_ps(zd, z_max);
    const auto sum = [&](__m128 a, __m128 b, __m128 c, __m128 d) {
      __m128 s = _mm_add_ps(zero, _mm_and_ps(ta, a));
      s = _mm_add_ps(s, _mm_and_ps(tb, b));
      s = _mm_add_ps(s, _mm_and_ps(tc, c));
      return _mm_add_ps(s, _mm_and_ps(td, d));
    };
    const __m128 sx = sum(xa, xb, xc, xd), sy = sum(ya, yb, yc, yd), sz = sum(za, zb, zc, zd);
    const __m128 count = _mm_add_ps(
        _mm_add_ps(_mm_add_ps(_mm_and_ps(ta, one), _mm_and_ps(tb, one)), _mm_and_ps(tc, one)),
        _mm_and_ps(td, one));
    const __m128 any = _mm_cmpgt_ps(count, zero);
    const auto pick = [&](__m128 mean) {
      return _mm_or_ps(_mm_and_ps(any, mean), _mm_andnot_ps(any, nan));
    };
    _mm_storeu_ps(x + k, pick(_mm_div_ps(sx, count)));
    _mm_storeu_ps(y + k, pick(_mm_div_ps(sy, count)));
    _mm_storeu_ps(z + k, pick(_mm_div_ps(sz, count)));
  }
  downsample_blocks(k, n, x0, y0, z0, x1, y1, z1, x, y, z);
}
#else
void downsample_row(std::size_t n, const float* x0, const float* y0, const float* z0,
                    const float* x1, const float* y1, const float* z1, float* x, float* y,
                    float* z) {
  downsample_blocks(0, n, x0, y0, z0, x1, y1, z1, x, y, z);
}
#endif

class ScenePyramid;

// One level of the scene pyramid: a window of the image at 1 / 2^level resolution, as three
// planes of floats (x, y, z; NaN where there is no point). Its pixels are readable once
// ensure'd: the pyramid fills them in tiles on first use.
struct Level {
  int u0 = 0, v0 = 0, width = 0, height = 0;
  int scale = 1;
  int index = 0;  // in its pyramid
  float* x = nullptr;
  float* y = nullptr;
  float* z = nullptr;
  ScenePyramid* pyramid = nullptr;
  std::size_t cell(int i, int j) const { return static_cast<std::size_t>(j) * width + i; }
  bool valid(int i, int j) const {
    const float d = z[cell(i, j)];
    return d == d;
  }
  Eigen::Vector3f at(int i, int j) const {
    const std::size_t c = cell(i, j);
    return {x[c], y[c], z[c]};
  }
  bool contains(int i, int j) const { return i >= 0 && j >= 0 && i < width && j < height; }
  // Makes pixels [i_lo, i_hi] x [j_lo, j_hi] (clipped to the window) readable.
  inline void ensure(int i_lo, int i_hi, int j_lo, int j_hi) const;
  // The same for one pixel inside the window.
  inline void ensure(int i, int j) const;
};

// The scene at every level the schedule uses, built in square tiles of the full-resolution
// image (aligned to multiples of their size, so each tile holds whole blocks of every level) the
// first time the registration reads one. A target fills a fraction of its crop's window: the
// tiles its model points never land near (nor their association windows and normals) are never
// read from the depth image, cropped nor averaged. A pixel's value depends neither on which
// tiles were built nor in which order, so neither does the pose.
class ScenePyramid {
 public:
  // Level 0 copied from a cloud, tile by tile.
  ScenePyramid(const OrganizedCloud& scene, int levels, Scratch& scratch) : cloud_(&scene) {
    init(scene.u0, scene.v0, scene.width, scene.height, levels, scratch);
  }
  // Level 0 cropped from the frame as crop_sphere crops it, tile by tile.
  ScenePyramid(const DepthFrame& frame, const detail::SphereCrop& crop, int levels,
               Scratch& scratch)
      : frame_(&frame), crop_(crop), rays_(std::in_place, frame, crop) {
    init(crop.u_lo, crop.v_lo, crop.width(), crop.height(), levels, scratch);
  }
  ScenePyramid(const ScenePyramid&) = delete;
  ScenePyramid& operator=(const ScenePyramid&) = delete;

  const Level& level(int l) const { return levels_[l]; }
  int levels() const { return static_cast<int>(levels_.size()); }
  // Valid full-resolution points in the tiles built so far.
  std::size_t level0_valid() const { return level0_valid_; }

  // ensure for one pixel inside level l's window.
  void ensure_pixel(int l, int i, int j) {
    const Level& level = levels_[l];
    const int shift = kTileShift - l;
    const int ti = ((level.u0 + i) >> shift) - tile_u0_, tj = ((level.v0 + j) >> shift) - tile_v0_;
    unsigned char& built = built_[static_cast<std::size_t>(tj) * tiles_wide_ + ti];
    if (!built) build_tile(ti, tj), built = 1;
  }

  void ensure(int l, int i_lo, int i_hi, int j_lo, int j_hi) {
    const Level& level = levels_[l];
    i_lo = std::max(i_lo, 0), j_lo = std::max(j_lo, 0);
    i_hi = std::min(i_hi, level.width - 1), j_hi = std::min(j_hi, level.height - 1);
    if (i_lo > i_hi || j_lo > j_hi) return;
    const int shift = kTileShift - l;
    const int ti_lo = ((level.u0 + i_lo) >> shift) - tile_u0_;
    const int ti_hi = ((level.u0 + i_hi) >> shift) - tile_u0_;
    const int tj_lo = ((level.v0 + j_lo) >> shift) - tile_v0_;
    const int tj_hi = ((level.v0 + j_hi) >> shift) - tile_v0_;
    for (int tj = tj_lo; tj <= tj_hi; ++tj) {
      unsigned char* built = built_ + static_cast<std::size_t>(tj) * tiles_wide_;
      for (int ti = ti_lo; ti <= ti_hi; ++ti) {
        if (!built[ti]) build_tile(ti, tj), built[ti] = 1;
      }
    }
  }

  // Tiles of 16 full-resolution pixels: whole blocks up to level 4, and about as wide as a
  // coarse association window, so a window seldom spans more than four.
  static constexpr int kTileShift = 4;
  static constexpr int kMaxLevels = kTileShift + 1;

 private:
  void init(int u0, int v0, int width, int height, int levels, Scratch& scratch) {
    if (levels > kMaxLevels) {
      throw std::invalid_argument("align_projective_icp: pyramid_level above " +
                                  std::to_string(kMaxLevels - 1));
    }
    levels_.resize(levels);
    for (int l = 0; l < levels; ++l) {
      Level& level = levels_[l];
      if (l == 0) {
        level.u0 = u0, level.v0 = v0, level.width = width, level.height = height;
      } else {
        const Level& fine = levels_[l - 1];
        level.scale = fine.scale * 2;
        level.u0 = fine.u0 >> 1;
        level.v0 = fine.v0 >> 1;
        level.width = std::max(0, ((fine.u0 + fine.width + 1) >> 1) - level.u0);
        level.height = std::max(0, ((fine.v0 + fine.height + 1) >> 1) - level.v0);
      }
      level.index = l;
      level.pyramid = this;
      const std::size_t cells = static_cast<std::size_t>(level.width) * level.height;
      level.x = scratch.take<float>(cells + kPlanePad);
      level.y = scratch.take<float>(cells + kPlanePad);
      level.z = scratch.take<float>(cells + kPlanePad);
    }
    tile_u0_ = u0 >> kTileShift;
    tile_v0_ = v0 >> kTileShift;
    tiles_wide_ = width > 0 ? ((u0 + width - 1) >> kTileShift) - tile_u0_ + 1 : 0;
    const int tiles_high = height > 0 ? ((v0 + height - 1) >> kTileShift) - tile_v0_ + 1 : 0;
    const std::size_t tiles = static_cast<std::size_t>(tiles_wide_) * tiles_high;
    built_ = scratch.take<unsigned char>(tiles);
    std::fill(built_, built_ + tiles, 0);
  }

  void build_tile(int ti, int tj) {
    const int U0 = (ti + tile_u0_) << kTileShift, V0 = (tj + tile_v0_) << kTileShift;
    {
      const Level& base = levels_[0];
      const int u_lo = std::max(U0, base.u0), u_hi = std::min(U0 + kTile, base.u0 + base.width);
      const int v_lo = std::max(V0, base.v0), v_hi = std::min(V0 + kTile, base.v0 + base.height);
      if (frame_ != nullptr) {
        // The tile's rows in one call: a vector loop of the tile's width with no remainder.
        const std::size_t row = base.cell(u_lo - base.u0, v_lo - base.v0);
        level0_valid_ +=
            detail::crop_rows(*frame_, crop_, *rays_, v_lo, v_hi, u_lo, u_hi, base.x + row,
                              base.y + row, base.z + row, static_cast<std::size_t>(base.width));
      } else {
        for (int v = v_lo; v < v_hi; ++v) {
          const std::size_t row = base.cell(u_lo - base.u0, v - base.v0);
          const Eigen::Vector3f* in = &cloud_->at(u_lo - base.u0, v - base.v0);
          for (int k = 0; k < u_hi - u_lo; ++k) {
            base.x[row + k] = in[k].x(), base.y[row + k] = in[k].y(), base.z[row + k] = in[k].z();
            level0_valid_ += OrganizedCloud::valid(in[k]);
          }
        }
      }
    }
    for (int l = 1; l < levels(); ++l) {
      const Level& fine = levels_[l - 1];
      const Level& coarse = levels_[l];
      const int u_lo = std::max(U0 >> l, coarse.u0);
      const int u_hi = std::min((U0 + kTile) >> l, coarse.u0 + coarse.width);
      const int v_lo = std::max(V0 >> l, coarse.v0);
      const int v_hi = std::min((V0 + kTile) >> l, coarse.v0 + coarse.height);
      for (int v = v_lo; v < v_hi; ++v) {
        const int fj = 2 * v - fine.v0;
        if (fj < 0 || fj + 1 >= fine.height) {
          for (int u = u_lo; u < u_hi; ++u) downsample(fine, coarse, u, v);
          continue;
        }
        // Blocks whose four children lie in the finer window, in one vectorized pass; those on
        // the window's left or right edge one by one.
        int u = u_lo;
        for (; u < u_hi && 2 * u - fine.u0 < 0; ++u) downsample(fine, coarse, u, v);
        int u_end = u_hi;
        while (u_end > u && 2 * (u_end - 1) - fine.u0 + 1 >= fine.width) --u_end;
        const std::size_t f0 = fine.cell(2 * u - fine.u0, fj), f1 = f0 + fine.width;
        const std::size_t out = coarse.cell(u - coarse.u0, v - coarse.v0);
        downsample_row(static_cast<std::size_t>(u_end - u), fine.x + f0, fine.y + f0, fine.z + f0,
                       fine.x + f1, fine.y + f1, fine.z + f1, coarse.x + out, coarse.y + out,
                       coarse.z + out);
        for (u = u_end; u < u_hi; ++u) downsample(fine, coarse, u, v);
      }
    }
  }

  // A coarser pixel averages the finer 2x2 block's points near its nearest one, so silhouette
  // edges stay sharp instead of blending foreground and background. The children count in row
  // order; those missing or outside the finer window are no points.
  static void downsample(const Level& fine, const Level& coarse, int u, int v) {
    const int fi = 2 * u - fine.u0, fj = 2 * v - fine.v0;
    float cx[4], cy[4], cz[4];
    int n = 0;
    for (int b = fj; b <= fj + 1; ++b) {
      for (int a = fi; a <= fi + 1; ++a) {
        if (!fine.contains(a, b)) continue;
        const std::size_t c = fine.cell(a, b);
        if (!(fine.z[c] == fine.z[c])) continue;
        cx[n] = fine.x[c], cy[n] = fine.y[c], cz[n] = fine.z[c];
        ++n;
      }
    }
    const std::size_t out = coarse.cell(u - coarse.u0, v - coarse.v0);
    if (n == 0) {
      coarse.x[out] = coarse.y[out] = coarse.z[out] = kNaN;
      return;
    }
    float z_min = cz[0];
    for (int k = 1; k < n; ++k) z_min = std::min(z_min, cz[k]);
    const float z_max = z_min * 1.02f;
    float sx = 0.0f, sy = 0.0f, sz = 0.0f;
    int count = 0;
    for (int k = 0; k < n; ++k) {
      if (cz[k] <= z_max) sx += cx[k], sy += cy[k], sz += cz[k], ++count;
    }
    const float f = static_cast<float>(count);
    coarse.x[out] = sx / f, coarse.y[out] = sy / f, coarse.z[out] = sz / f;
  }

  static constexpr int kTile = 1 << kTileShift;
  const OrganizedCloud* cloud_ = nullptr;
  const DepthFrame* frame_ = nullptr;
  detail::SphereCrop crop_;
  std::optional<detail::WindowRays> rays_;
  std::size_t level0_valid_ = 0;
  std::vector<Level> levels_;
  int tile_u0_ = 0, tile_v0_ = 0, tiles_wide_ = 0;
  unsigned char* built_ = nullptr;
};

void Level::ensure(int i_lo, int i_hi, int j_lo, int j_hi) const {
  pyramid->ensure(index, i_lo, i_hi, j_lo, j_hi);
}

void Level::ensure(int i, int j) const {
  pyramid->ensure_pixel(index, i, j);
}

}  // namespace
}  // namespace projtour::perception
