// Point-to-plane ICP with projective data association through the organized depth image.
#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <random>

#include <stdexcept>
#include <string>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "crop_internal.hpp"
#include "projtour/geometry.hpp"
#include "projtour/registration.hpp"
#include "vector_clones.hpp"

namespace projtour {

std::vector<IcpStage> IcpOptions::default_stages() {
  // Coarse levels see the whole target in few pixels, and their window lets a model point find
  // its surface several centimetres away; the fine levels then settle on the noise floor.
  return {
      {4, 250, 1, 0.15, 6, true}, {3, 250, 1, 0.10, 6},  {2, 500, 1, 0.04, 5},
      {1, 1000, 0, 0.02, 4},      {0, 4500, 0, 0.01, 2},
  };
}

IcpModel::IcpModel(const ModelCloud& cloud, unsigned seed)
    : bounding_radius_m_(cloud.bounding_radius_m) {
  if (cloud.points.size() != cloud.normals.size()) {
    throw std::invalid_argument("IcpModel: points and normals differ in number");
  }
  std::vector<std::size_t> order(cloud.points.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(seed);
  // Fisher-Yates with our own draw: std::shuffle's sequence differs between standard libraries.
  for (std::size_t i = order.size(); i > 1; --i) {
    std::swap(order[i - 1], order[rng() % i]);
  }
  points_.reserve(order.size());
  normals_.reserve(order.size());
  for (std::size_t i : order) {
    points_.push_back(cloud.points[i]);
    normals_.push_back(cloud.normals[i].normalized());
  }
  if (bounding_radius_m_ <= 0.0f) {
    for (const auto& p : points_) bounding_radius_m_ = std::max(bounding_radius_m_, p.norm());
  }
  const std::size_t n = points_.size();
  columns_.resize(6 * n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) {
      columns_[c * n + k] = points_[k][c];
      columns_[(3 + c) * n + k] = normals_[k][c];
    }
  }
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// A pyramid level's planes hold this many floats past their last pixel, so the nearest-point
// search may read a row's last group of four past the window's right edge (those lanes are
// masked before they count).
#if defined(__SSE2__)
constexpr std::size_t kPlanePad = 4;
#else
constexpr std::size_t kPlanePad = 0;
#endif

// Buffers an alignment fills anew and throws away: kept per thread from one alignment to the
// next, so the tracking loop allocates (and the kernel maps fresh pages) only on its first frames.
// Every element is written before it is read, so nothing carries over between alignments.
class Scratch {
 public:
  template <typename T>
  T* take(std::size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::size_t bytes = (n * sizeof(T) + 63) & ~std::size_t{63};
    if (used_ == blocks_.size()) blocks_.emplace_back();
    Block& block = blocks_[used_++];
    if (block.bytes < bytes) {
      // Grown with room to spare: the same call takes somewhat more on another frame.
      block.bytes = bytes + bytes / 2;
      block.data.reset(new std::max_align_t[block.bytes / sizeof(std::max_align_t) + 1]);
    }
    return reinterpret_cast<T*>(block.data.get());
  }

  // One per alignment on the thread's stack of them (an alignment inside a visit callback gets
  // its own).
  class Lease {
   public:
    Lease() {
      if (pool().empty()) pool().push_back(std::make_unique<Scratch>());
      scratch_ = std::move(pool().back());
      pool().pop_back();
      scratch_->used_ = 0;
    }
    ~Lease() { pool().push_back(std::move(scratch_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Scratch& operator*() { return *scratch_; }

   private:
    std::unique_ptr<Scratch> scratch_;
  };

 private:
  static std::vector<std::unique_ptr<Scratch>>& pool() {
    thread_local std::vector<std::unique_ptr<Scratch>> scratches;
    return scratches;
  }
  struct Block {
    std::unique_ptr<std::max_align_t[]> data;
    std::size_t bytes = 0;
  };
  std::vector<Block> blocks_;
  std::size_t used_ = 0;
};

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

// The model's first n points and normals in the camera frame, as planes, with where each lands
// in the depth image: u, v in full-resolution pixels shifted by half a pixel (so truncating them
// at any level gives the pixel's index), and `seen` for those facing the camera in front of it
// (only the side facing the camera can be seen; the back side would otherwise match the support
// plane or the far surface of the target itself).
struct MovedModel {
  std::size_t n = 0;
  float *px, *py, *pz, *nx, *ny, *nz, *u, *v;
  int* seen;
  // After land(level, count): the `hits` of the first `count` points seen inside the level's
  // window, in index order, at hit[0, hits); point k lands on pixel (i[k], j[k]).
  int *i, *j, *in, *hit;
  std::size_t hits = 0;
  MovedModel(std::size_t capacity, Scratch& scratch) {
    for (float** plane : {&px, &py, &pz, &nx, &ny, &nz, &u, &v}) {
      *plane = scratch.take<float>(capacity);
    }
    for (int** plane : {&seen, &i, &j, &in}) *plane = scratch.take<int>(capacity);
    hit = scratch.take<int>(capacity + 4);  // gather_hits writes whole groups of four
  }
  Eigen::Vector3f p(std::size_t k) const { return {px[k], py[k], pz[k]}; }
  Eigen::Vector3f normal(std::size_t k) const { return {nx[k], ny[k], nz[k]}; }
  inline void land(const Level& level, std::size_t count);
};

// MovedModel::land's pixels in one pass the compiler vectorizes: every point's pixel, and
// whether it is seen inside the window.
PROJTOUR_VECTOR_CLONES void land_points(std::size_t n, const float* __restrict__ u,
                                        const float* __restrict__ v, const int* __restrict__ seen,
                                        float inv_scale, int u0, int v0, int width, int height,
                                        int* __restrict__ i, int* __restrict__ j,
                                        int* __restrict__ in) {
  for (std::size_t k = 0; k < n; ++k) {
    const int a = static_cast<int>(u[k] * inv_scale) - u0;
    const int b = static_cast<int>(v[k] * inv_scale) - v0;
    i[k] = a, j[k] = b;
    // One unsigned comparison per axis rejects both sides of the window.
    in[k] = seen[k] & (static_cast<unsigned>(a) < static_cast<unsigned>(width)) &
            (static_cast<unsigned>(b) < static_cast<unsigned>(height));
  }
}

// The indices k in [0, n) with in[k] set, in order, at hit[0, returned); hit has room for n + 4.
// Without a branch to mispredict: every index (or group of four) is written, only hits advance.
std::size_t gather_hits(std::size_t n, const int* __restrict__ in, int* __restrict__ hit) {
  std::size_t m = 0, k = 0;
#if defined(__SSE2__)
  // For each pattern of four flags, the lanes set, in order, and how many.
  struct Pattern {
    alignas(16) int lanes[4];
    int count;
  };
  static constexpr Pattern kPatterns[16] = {
      {{0, 0, 0, 0}, 0}, {{0, 0, 0, 0}, 1}, {{1, 0, 0, 0}, 1}, {{0, 1, 0, 0}, 2},
      {{2, 0, 0, 0}, 1}, {{0, 2, 0, 0}, 2}, {{1, 2, 0, 0}, 2}, {{0, 1, 2, 0}, 3},
      {{3, 0, 0, 0}, 1}, {{0, 3, 0, 0}, 2}, {{1, 3, 0, 0}, 2}, {{0, 1, 3, 0}, 3},
      {{2, 3, 0, 0}, 2}, {{0, 2, 3, 0}, 3}, {{1, 2, 3, 0}, 3}, {{0, 1, 2, 3}, 4},
  };
  const __m128i zero = _mm_setzero_si128();
  for (; k + 4 <= n; k += 4) {
    const __m128i flags = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + k));
    const int mask = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpgt_epi32(flags, zero)));
    const Pattern& p = kPatterns[mask];
    const __m128i lanes = _mm_load_si128(reinterpret_cast<const __m128i*>(p.lanes));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(hit + m),
                     _mm_add_epi32(lanes, _mm_set1_epi32(static_cast<int>(k))));
    m += static_cast<std::size_t>(p.count);
  }
#endif
  for (; k < n; ++k) hit[m] = static_cast<int>(k), m += static_cast<std::size_t>(in[k]);
  return m;
}

void MovedModel::land(const Level& level, std::size_t count) {
  land_points(count, u, v, seen, 1.0f / static_cast<float>(level.scale), level.u0, level.v0,
              level.width, level.height, i, j, in);
  hits = gather_hits(count, in, hit);
}

// A pixel beyond this is off any image; it keeps the conversion to int in range.
constexpr float kFarPixel = 1e7f;

// Projector::move's loop, on its own so that the arrays are known not to overlap.
PROJTOUR_VECTOR_CLONES void move_points(
    std::size_t n, const float* pose, const float* camera, const float* __restrict__ mx,
    const float* __restrict__ my, const float* __restrict__ mz, const float* __restrict__ mnx,
    const float* __restrict__ mny, const float* __restrict__ mnz, float* __restrict__ px,
    float* __restrict__ py, float* __restrict__ pz, float* __restrict__ nx, float* __restrict__ ny,
    float* __restrict__ nz, float* __restrict__ u, float* __restrict__ v, int* __restrict__ seen) {
  const float r00 = pose[0], r01 = pose[1], r02 = pose[2], r10 = pose[3], r11 = pose[4],
              r12 = pose[5], r20 = pose[6], r21 = pose[7], r22 = pose[8];
  const float t0 = pose[9], t1 = pose[10], t2 = pose[11];
  const float o0 = camera[0], o1 = camera[1], o2 = camera[2];
  const float fx = camera[3], fy = camera[4], cx = camera[5], cy = camera[6];
  for (std::size_t k = 0; k < n; ++k) {
    const float x = r00 * mx[k] + r01 * my[k] + r02 * mz[k] + t0;
    const float y = r10 * mx[k] + r11 * my[k] + r12 * mz[k] + t1;
    const float z = r20 * mx[k] + r21 * my[k] + r22 * mz[k] + t2;
    const float a = r00 * mnx[k] + r01 * mny[k] + r02 * mnz[k];
    const float b = r10 * mnx[k] + r11 * mny[k] + r12 * mnz[k];
    const float c = r20 * mnx[k] + r21 * mny[k] + r22 * mnz[k];
    const float dx = x - o0, dy = y - o1, dz = z - o2;
    const float inv_z = 1.0f / dz;
    const float pu = fx * dx * inv_z + cx, pv = fy * dy * inv_z + cy;
    px[k] = x, py[k] = y, pz[k] = z, nx[k] = a, ny[k] = b, nz[k] = c;
    // NaN and out-of-range pixels fail these tests, and are zeroed so the int conversion
    // downstream stays defined.
    const bool in = (a * dx + b * dy + c * dz < 0.0f) & (dz > 1e-3f) & (pu >= 0.0f) & (pv >= 0.0f) &
                    (pu < kFarPixel) & (pv < kFarPixel);
    u[k] = in ? pu : 0.0f;
    v[k] = in ? pv : 0.0f;
    seen[k] = in;
  }
}

// Projects camera-frame points into the depth image.
class Projector {
 public:
  Projector(const PinholeModel& intrinsics, const Eigen::Vector3f& depth_to_color_m)
      : k_(intrinsics),
        distorted_(intrinsics.has_distortion()),
        origin_(depth_to_color_m),
        fx_(static_cast<float>(k_.fx)),
        fy_(static_cast<float>(k_.fy)),
        cx_(static_cast<float>(k_.cx + 0.5)),
        cy_(static_cast<float>(k_.cy + 0.5)) {}
  explicit Projector(const OrganizedCloud& scene)
      : Projector(scene.intrinsics, scene.depth_to_color_m) {}
  // The depth camera's centre in the camera frame: where view rays start.
  const Eigen::Vector3f& origin() const { return origin_; }

  // One pass over plain arrays of floats, which the compiler turns into vector instructions:
  // every point is moved and projected whether or not it is seen, and `seen` says which count.
  // `out` holds room for n points.
  void move(const IcpModel& model, std::size_t n, const Eigen::Isometry3d& T,
            MovedModel& out) const {
    out.n = n;
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    const float pose[12] = {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2),
                            R(2, 0), R(2, 1), R(2, 2), t.x(),   t.y(),   t.z()};
    const float camera[7] = {origin_.x(), origin_.y(), origin_.z(), fx_, fy_, cx_, cy_};
    move_points(n, pose, camera, model.column(0), model.column(1), model.column(2), model.column(3),
                model.column(4), model.column(5), out.px, out.py, out.pz, out.nx, out.ny, out.nz,
                out.u, out.v, out.seen);
    if (!distorted_) return;
    // The distortion model is solved in double, point by point, over the first pass's result.
    const float o0 = origin_.x(), o1 = origin_.y(), o2 = origin_.z();
    const float *px = out.px, *py = out.py, *pz = out.pz, *nx = out.nx, *ny = out.ny, *nz = out.nz;
    float *u = out.u, *v = out.v;
    int* seen = out.seen;
    for (std::size_t k = 0; k < n; ++k) {
      const float dz = pz[k] - o2;
      const bool facing = nx[k] * (px[k] - o0) + ny[k] * (py[k] - o1) + nz[k] * dz < 0.0f;
      seen[k] = 0;
      u[k] = v[k] = 0.0f;
      if (!facing || !(dz > 1e-3f)) continue;
      const auto px_d = k_.project(Eigen::Vector3d(px[k] - o0, py[k] - o1, dz));
      if (!px_d) continue;
      const float pu = static_cast<float>(px_d->x() + 0.5),
                  pv = static_cast<float>(px_d->y() + 0.5);
      if (!(pu >= 0.0f && pv >= 0.0f && pu < kFarPixel && pv < kFarPixel)) continue;
      u[k] = pu, v[k] = pv, seen[k] = 1;
    }
  }

 private:
  const PinholeModel& k_;
  bool distorted_;
  Eigen::Vector3f origin_;
  float fx_, fy_, cx_, cy_;
};

// Scene normal at a pixel from its neighbours `step` pixels away, facing the camera; zero
// when the neighbourhood has too few points.
Eigen::Vector3f scene_normal(const Level& level, int i, int j, int step,
                             const Eigen::Vector3f& view_origin) {
  Eigen::Vector3f points[5];
  auto valid_at = [&](int a, int b, int slot) -> const Eigen::Vector3f* {
    if (!level.contains(a, b) || !level.valid(a, b)) return nullptr;
    points[slot] = level.at(a, b);
    return &points[slot];
  };
  const Eigen::Vector3f* c = valid_at(i, j, 0);
  const Eigen::Vector3f* r = valid_at(i + step, j, 1);
  const Eigen::Vector3f* l = valid_at(i - step, j, 2);
  const Eigen::Vector3f* d = valid_at(i, j + step, 3);
  const Eigen::Vector3f* u = valid_at(i, j - step, 4);
  const Eigen::Vector3f* h0 = l ? l : c;
  const Eigen::Vector3f* h1 = r ? r : c;
  const Eigen::Vector3f* v0 = u ? u : c;
  const Eigen::Vector3f* v1 = d ? d : c;
  if (h0 == h1 || v0 == v1) return Eigen::Vector3f::Zero();
  Eigen::Vector3f n = (*h1 - *h0).cross(*v1 - *v0);
  const float norm = n.norm();
  if (norm <= 0.0f) return Eigen::Vector3f::Zero();
  n /= norm;
  if (n.dot(*c - view_origin) > 0.0f) n = -n;
  return n;
}

// Scene normals from neighbours this far apart: wide enough at full resolution to see through
// the sensor noise, adjacent at the coarse levels where averaging already smoothed it.
int normal_step(const Level& level) {
  return level.scale == 1 ? 2 : 1;
}

// scene_normal per pixel of one pyramid level, each solved on first use.
class SceneNormals {
 public:
  SceneNormals(const Level& level, Scratch& scratch) : level_(level), step_(normal_step(level)) {
    const std::size_t n = static_cast<std::size_t>(level.width) * level.height;
    solved_ = scratch.take<unsigned char>(n);
    std::fill(solved_, solved_ + n, 0);
    for (float*& plane : normals_) plane = scratch.take<float>(n);  // written when solved
  }
  Eigen::Vector3f at(int i, int j, const Eigen::Vector3f& view_origin) {
    const std::size_t k = level_.cell(i, j);
    if (!solved_[k]) {
      level_.ensure(i - step_, i + step_, j - step_, j + step_);
      const Eigen::Vector3f n = scene_normal(level_, i, j, step_, view_origin);
      for (int c = 0; c < 3; ++c) normals_[c][k] = n[c];
      solved_[k] = 1;
    }
    return {normals_[0][k], normals_[1][k], normals_[2][k]};
  }

 private:
  const Level& level_;
  int step_;
  unsigned char* solved_;
  float* normals_[3];
};

// The first nearest scene point in row-major order to p over rows [j_lo, j_hi] and columns
// [i_lo, i_hi]: the scalar search, and where the window lies inside the level and is at most 8
// wide (the coarse stages' +-1 and +-2) its rows four columns at a time. Both compute each
// distance with the same operations in the same order and keep the same pixel: a NaN distance
// (no point) never compares below the best, and a lane keeps the earliest row of its minimum.
bool nearest_scalar(const Level& level, const Eigen::Vector3f& p, int i_lo, int i_hi, int j_lo,
                    int j_hi, int& qi, int& qj) {
  float best = std::numeric_limits<float>::max();
  for (int b = j_lo; b <= j_hi; ++b) {
    const std::size_t row = level.cell(0, b);
    for (int a = i_lo; a <= i_hi; ++a) {
      const float dz = level.z[row + a] - p.z();
      if (!(dz == dz)) continue;
      const float dx = level.x[row + a] - p.x(), dy = level.y[row + a] - p.y();
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < best) best = d2, qi = a, qj = b;
    }
  }
  return best != std::numeric_limits<float>::max();
}

#if defined(__SSE2__)
// The same search four columns at a time, for windows up to 8 wide.
bool nearest_narrow(const Level& level, const Eigen::Vector3f& p, int i_lo, int i_hi, int j_lo,
                    int j_hi, int& qi, int& qj) {
  const int w = i_hi - i_lo + 1;
  const __m128 far = _mm_set1_ps(std::numeric_limits<float>::max());
  const __m128 px = _mm_set1_ps(p.x()), py = _mm_set1_ps(p.y()), pz = _mm_set1_ps(p.z());
  const __m128i lane = _mm_setr_epi32(0, 1, 2, 3);
  const __m128 keep0 = _mm_castsi128_ps(_mm_cmplt_epi32(lane, _mm_set1_epi32(w)));
  const __m128 keep1 = _mm_castsi128_ps(_mm_cmplt_epi32(lane, _mm_set1_epi32(w - 4)));
  const auto select = [](__m128 mask, __m128 a, __m128 b) {
    return _mm_or_ps(_mm_and_ps(mask, a), _mm_andnot_ps(mask, b));
  };
  const auto distances = [&](std::size_t c, __m128 keep) {
    const __m128 dz = _mm_sub_ps(_mm_loadu_ps(level.z + c), pz);
    const __m128 dx = _mm_sub_ps(_mm_loadu_ps(level.x + c), px);
    const __m128 dy = _mm_sub_ps(_mm_loadu_ps(level.y + c), py);
    const __m128 d2 =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    return select(keep, d2, far);
  };
  __m128 best0 = far, best1 = far;
  __m128 row0 = _mm_setzero_ps(), row1 = _mm_setzero_ps();  // rows as int bits
  for (int b = j_lo; b <= j_hi; ++b) {
    const std::size_t c = level.cell(i_lo, b);
    const __m128 row = _mm_castsi128_ps(_mm_set1_epi32(b));
    const __m128 d0 = distances(c, keep0);
    const __m128 less0 = _mm_cmplt_ps(d0, best0);
    best0 = select(less0, d0, best0), row0 = select(less0, row, row0);
    if (w > 4) {
      const __m128 d1 = distances(c + 4, keep1);
      const __m128 less1 = _mm_cmplt_ps(d1, best1);
      best1 = select(less1, d1, best1), row1 = select(less1, row, row1);
    }
  }
  alignas(16) float best[8];
  alignas(16) int rows[8];
  _mm_store_ps(best, best0), _mm_store_ps(best + 4, best1);
  _mm_store_si128(reinterpret_cast<__m128i*>(rows), _mm_castps_si128(row0));
  _mm_store_si128(reinterpret_cast<__m128i*>(rows + 4), _mm_castps_si128(row1));
  float m = std::numeric_limits<float>::max();
  for (int a = 0; a < w; ++a) m = std::min(m, best[a]);
  if (m == std::numeric_limits<float>::max()) return false;
  // Among the columns reaching the minimum, the earliest row, then the leftmost column.
  int first = -1;
  for (int a = 0; a < w; ++a) {
    if (best[a] == m && (first < 0 || rows[a] < rows[first])) first = a;
  }
  qi = i_lo + first, qj = rows[first];
  return true;
}
#endif

bool nearest_in_window(const Level& level, const Eigen::Vector3f& p, int i_lo, int i_hi, int j_lo,
                       int j_hi, int& qi, int& qj) {
#if defined(__SSE2__)
  if (i_hi - i_lo < 8) return nearest_narrow(level, p, i_lo, i_hi, j_lo, j_hi, qi, qj);
#endif
  return nearest_scalar(level, p, i_lo, i_hi, j_lo, j_hi, qi, qj);
}

// The scene point for a model point at pixel (i, j): there, or the nearest within +-radius.
bool associate(const Level& level, const Eigen::Vector3f& p, int i, int j, int radius_px,
               Eigen::Vector3f& q, int& qi, int& qj) {
  if (radius_px == 0) {
    level.ensure(i, j);
    if (!level.valid(i, j)) return false;
    q = level.at(i, j), qi = i, qj = j;
    return true;
  }
  const int i_lo = std::max(0, i - radius_px), i_hi = std::min(level.width - 1, i + radius_px);
  const int j_lo = std::max(0, j - radius_px), j_hi = std::min(level.height - 1, j + radius_px);
  level.ensure(i_lo, i_hi, j_lo, j_hi);
  if (!nearest_in_window(level, p, i_lo, i_hi, j_lo, j_hi, qi, qj)) return false;
  q = level.at(qi, qj);
  return true;
}

Eigen::Isometry3d apply_twist(const Eigen::Matrix<double, 6, 1>& xi, const Eigen::Isometry3d& T) {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = xi.head<3>();
  const double angle = w.norm();
  if (angle > 0.0) delta.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  delta.translation() = xi.tail<3>();
  Eigen::Isometry3d out = delta * T;
  // Re-orthonormalize so thousands of small updates never drift off SO(3).
  out.linear() = Eigen::Quaterniond(out.linear()).normalized().toRotationMatrix();
  return out;
}

// The Gauss-Newton system of point-to-plane matches: J = (p x n, n), summed as w J J^T and
// w r J. The matches are kept as planes and, once the association is done, weighed and turned
// into J and w J in passes the compiler vectorizes, then summed in lanes of floats lane by lane
// in a fixed order, so the sums are the same on every run.
class NormalEquations {
 public:
  NormalEquations(std::size_t capacity, Scratch& scratch) {
    for (float*& plane : matches_) plane = scratch.take<float>(capacity);
    for (float*& plane : kept_planes_) plane = scratch.take<float>(capacity);
    weights_ = scratch.take<float>(capacity);
    kept_ = scratch.take<int>(capacity);
    // Room for a whole last block of lanes, zeroed before each sum.
    for (float*& plane : planes_) plane = scratch.take<float>(capacity + kLanes);
  }
  void clear() { m_ = 0; }
  std::size_t size() const { return m_; }
  // A match: the model point p, its normal n and the point-to-plane residual r, all in the
  // camera frame.
  void add(const Eigen::Vector3f& p, const Eigen::Vector3f& n, float r) {
    matches_[0][m_] = p.x(), matches_[1][m_] = p.y(), matches_[2][m_] = p.z();
    matches_[3][m_] = n.x(), matches_[4][m_] = n.y(), matches_[5][m_] = n.z();
    matches_[6][m_] = r;
    ++m_;
  }
  // Tukey's biweight of each residual over tukey_c (none when tukey_c <= 0, all weigh 1); the
  // matches beyond it drop out. Then J and w J of those kept, in their order.
  void weigh(double tukey_c) {
    tukey_weights(m_, matches_[6], tukey_c, weights_, kept_);
    float* const* J = planes_;
    const float* const* kept = matches_;
    const float* w = weights_;
    if (tukey_c > 0.0) {
      // Gathered without a branch: every match is written, only those kept advance.
      std::size_t m = 0;
      for (std::size_t k = 0; k < m_; ++k) {
        for (int c = 0; c < 6; ++c) kept_planes_[c][m] = matches_[c][k];
        kept_planes_[6][m] = weights_[k], planes_[12][m] = matches_[6][k];
        m += static_cast<std::size_t>(kept_[k]);
      }
      kept_count_ = m;
      kept = kept_planes_, w = kept_planes_[6];
    } else {
      // All kept, all weigh 1: the matches as they are.
      std::copy(matches_[6], matches_[6] + m_, planes_[12]);
      kept_count_ = m_;
    }
    jacobians(kept_count_, kept[0], kept[1], kept[2], kept[3], kept[4], kept[5], w, J[0], J[1],
              J[2], J[3], J[4], J[5], J[6], J[7], J[8], J[9], J[10], J[11]);
  }
  void solve_inputs(Eigen::Matrix<double, 6, 6>& H, Eigen::Matrix<double, 6, 1>& g) {
    // The last block padded with zero weights, so every block is whole.
    const std::size_t blocks = (kept_count_ + kLanes - 1) / kLanes;
    for (std::size_t k = kept_count_; k < blocks * kLanes; ++k) {
      for (float* plane : planes_) plane[k] = 0.0f;
    }
    // Sum by sum over all blocks, so a sum's lanes stay in registers.
    for (int a = 0; a < 6; ++a) {
      for (int b = 0; b <= a; ++b)
        H(a, b) = H(b, a) = sum_products(blocks, planes_[6 + a], planes_[b]);
      g[a] = sum_products(blocks, planes_[6 + a], planes_[12]);
    }
  }

 private:
  static constexpr int kLanes = 8;
  PROJTOUR_VECTOR_CLONES static void tukey_weights(std::size_t n, const float* __restrict__ r,
                                                   double tukey_c, float* __restrict__ w,
                                                   int* __restrict__ kept) {
    if (!(tukey_c > 0.0)) {
      for (std::size_t k = 0; k < n; ++k) w[k] = 1.0f, kept[k] = 1;
      return;
    }
    for (std::size_t k = 0; k < n; ++k) {
      const double u = static_cast<double>(r[k]) / tukey_c;
      const double v = 1.0 - u * u;
      w[k] = static_cast<float>(v * v);
      kept[k] = !(std::abs(u) >= 1.0);
    }
  }
  // J = (p x n, n) and w J of the kept matches (planes p, n, w), into planes 0-5 and 6-11.
  PROJTOUR_VECTOR_CLONES static void jacobians(
      std::size_t n, const float* __restrict__ px, const float* __restrict__ py,
      const float* __restrict__ pz, const float* __restrict__ nx, const float* __restrict__ ny,
      const float* __restrict__ nz, const float* __restrict__ w, float* __restrict__ j0,
      float* __restrict__ j1, float* __restrict__ j2, float* __restrict__ j3,
      float* __restrict__ j4, float* __restrict__ j5, float* __restrict__ w0,
      float* __restrict__ w1, float* __restrict__ w2, float* __restrict__ w3,
      float* __restrict__ w4, float* __restrict__ w5) {
    for (std::size_t k = 0; k < n; ++k) {
      // Eigen's cross product, term by term.
      const float a = py[k] * nz[k] - pz[k] * ny[k];
      const float b = pz[k] * nx[k] - px[k] * nz[k];
      const float c = px[k] * ny[k] - py[k] * nx[k];
      j0[k] = a, j1[k] = b, j2[k] = c, j3[k] = nx[k], j4[k] = ny[k], j5[k] = nz[k];
      w0[k] = w[k] * a, w1[k] = w[k] * b, w2[k] = w[k] * c;
      w3[k] = w[k] * nx[k], w4[k] = w[k] * ny[k], w5[k] = w[k] * nz[k];
    }
  }
  // Sum of a[k] b[k] over whole blocks: lane by lane in block order, then the lanes in order.
  PROJTOUR_VECTOR_CLONES static double sum_products(std::size_t blocks, const float* __restrict__ a,
                                                    const float* __restrict__ b) {
    float lanes[kLanes] = {};
    for (std::size_t block = 0; block < blocks; ++block) {
      const std::size_t k0 = block * kLanes;
      for (int lane = 0; lane < kLanes; ++lane) lanes[lane] += a[k0 + lane] * b[k0 + lane];
    }
    double total = 0.0;
    for (int lane = 0; lane < kLanes; ++lane) total += lanes[lane];
    return total;
  }
  float* matches_[7];      // p, n, r of every match
  float* kept_planes_[7];  // p, n, w of those kept
  float* weights_;
  int* kept_;
  float* planes_[13];
  std::size_t m_ = 0, kept_count_ = 0;
};

// The model's own depth image at 1/4 resolution (every model point facing the camera splatted
// into its cell), so points hidden behind another part of the model (the ears, the far flank)
// count neither for nor against a pose.
float* model_depth_buffer(MovedModel& moved, const Level& grid, const Projector& projector,
                          Scratch& scratch) {
  const std::size_t cells = static_cast<std::size_t>(grid.width) * grid.height;
  float* z_buffer = scratch.take<float>(cells);
  std::fill(z_buffer, z_buffer + cells, std::numeric_limits<float>::infinity());
  // A prefix dense enough to cover every cell of a target at working distance.
  moved.land(grid, std::min<std::size_t>(moved.n, 8000));
  for (std::size_t h = 0; h < moved.hits; ++h) {
    const int k = moved.hit[h];
    float& z = z_buffer[grid.cell(moved.i[k], moved.j[k])];
    z = std::min(z, moved.pz[k] - projector.origin().z());
  }
  return z_buffer;
}

// The model points align's quality judges by: facing the camera, not hidden behind the model's
// own parts, in the scene window, with a scene point within inlier_distance_m. `visit(k, p, n,
// q)` gets each (model index, model point and normal in the camera frame, scene point);
// returns the candidates' count.
template <typename Visit>
std::size_t visit_inliers(const IcpModel& model, const Level& level, const Projector& projector,
                          const Eigen::Isometry3d& T, const IcpOptions& options,
                          std::size_t max_model_points, Scratch& scratch, Visit&& visit) {
  Level grid;  // geometry only
  grid.scale = level.scale * 4;
  grid.u0 = level.u0 >> 2;
  grid.v0 = level.v0 >> 2;
  grid.width = ((level.u0 + level.width + 3) >> 2) - grid.u0;
  grid.height = ((level.v0 + level.height + 3) >> 2) - grid.v0;
  const std::size_t n_model = std::min<std::size_t>(model.size(), max_model_points);
  const std::size_t n_moved =
      std::max<std::size_t>(n_model, std::min<std::size_t>(model.size(), 8000));
  MovedModel moved(n_moved, scratch);
  projector.move(model, n_moved, T, moved);
  const float* z_buffer = model_depth_buffer(moved, grid, projector, scratch);
  const float inlier_m = static_cast<float>(options.inlier_distance_m);
  const float hidden_m = std::max(0.01f, 2.0f * inlier_m);
  std::size_t candidates = 0;
  moved.land(level, n_model);
  for (std::size_t h = 0; h < moved.hits; ++h) {
    const int k = moved.hit[h], i = moved.i[k], j = moved.j[k];
    // The grid's cells are blocks of 4x4 of the level's pixels, and hold its whole window.
    const float z_front =
        z_buffer[grid.cell(((level.u0 + i) >> 2) - grid.u0, ((level.v0 + j) >> 2) - grid.v0)];
    if (moved.pz[k] - projector.origin().z() > z_front + hidden_m) continue;
    ++candidates;
    level.ensure(i, j);
    if (!level.valid(i, j)) continue;
    const Eigen::Vector3f p = moved.p(k), q = level.at(i, j);
    if ((q - p).norm() > inlier_m) continue;
    visit(k, p, moved.normal(k), q);
  }
  return candidates;
}

void measure_quality(const IcpModel& model, const Level& level, const Projector& projector,
                     const Eigen::Isometry3d& T, const IcpOptions& options, Scratch& scratch,
                     RegistrationResult& result) {
  // A few thousand points pin a fraction down to about a percent; more only cost time.
  std::size_t inliers = 0;
  double sum_sq = 0.0;
  const std::size_t candidates =
      visit_inliers(model, level, projector, T, options, 3000, scratch,
                    [&](std::size_t, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                        const Eigen::Vector3f& q) {
                      ++inliers;
                      const double r = n.dot(p - q);
                      sum_sq += r * r;
                    });
  result.inliers = inliers;
  result.inlier_fraction = candidates > 0 ? static_cast<double>(inliers) / candidates : 0.0;
  result.rmse_mm = inliers > 0 ? 1000.0 * std::sqrt(sum_sq / inliers) : 0.0;
}

RegistrationResult run_schedule(const IcpModel& model, const ScenePyramid& pyramid,
                                const Projector& projector, const Eigen::Isometry3d& guess,
                                const IcpOptions& options, Scratch& scratch) {
  RegistrationResult result;
  const float cos_max_angle =
      static_cast<float>(std::cos(options.max_normal_angle_deg * kPi / 180.0));

  Eigen::Isometry3d T = guess;
  bool every_stage_matched = true;
  // Scene normals are solved for a pixel the first time a match lands there and kept for the
  // frame's later iterations, which land mostly on the same pixels.
  std::vector<std::optional<SceneNormals>> normals(pyramid.levels());
  std::size_t most_points = 0;
  for (const IcpStage& stage : options.stages) {
    most_points = std::max<std::size_t>(most_points, std::max(0, stage.max_model_points));
  }
  most_points = std::min(most_points, model.size());
  NormalEquations equations(most_points, scratch);
  MovedModel moved(most_points, scratch);
  for (const IcpStage& stage : options.stages) {
    const Level& level = pyramid.level(stage.pyramid_level);
    auto& level_normals = normals[stage.pyramid_level];
    if (!level_normals) level_normals.emplace(level, scratch);
    const std::size_t n_model = std::min<std::size_t>(
        model.size(), static_cast<std::size_t>(std::max(0, stage.max_model_points)));
    const float max_d2 = static_cast<float>(stage.max_distance_m * stage.max_distance_m);
    const double tukey_c = options.tukey_scale * stage.max_distance_m;
    for (int it = 0; it < stage.iterations; ++it) {
      projector.move(model, n_model, T, moved);
      equations.clear();
      moved.land(level, n_model);
      for (std::size_t h = 0; h < moved.hits; ++h) {
        const int k = moved.hit[h], i = moved.i[k], j = moved.j[k];
        const Eigen::Vector3f p = moved.p(k);
        Eigen::Vector3f q;
        int qi, qj;
        if (!associate(level, p, i, j, stage.search_radius_px, q, qi, qj)) continue;
        if ((q - p).squaredNorm() > max_d2) continue;
        const Eigen::Vector3f n = moved.normal(k);
        const Eigen::Vector3f ns = level_normals->at(qi, qj, projector.origin());
        if (ns.isZero() || ns.dot(n) < cos_max_angle) continue;
        equations.add(p, n, n.dot(p - q));
      }
      ++result.iterations;
      if (equations.size() < 12) {
        every_stage_matched = false;
        break;
      }
      Eigen::Matrix<double, 6, 6> H;
      Eigen::Matrix<double, 6, 1> g;
      equations.weigh(tukey_c);
      equations.solve_inputs(H, g);
      // A touch of damping keeps a flat or symmetric patch from making the solve singular.
      H.diagonal().array() += 1e-9 + 1e-6 * H.diagonal().maxCoeff();
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      if (stage.translation_only) {
        xi.tail<3>() = H.bottomRightCorner<3, 3>().ldlt().solve(-g.tail<3>());
      } else {
        xi = H.ldlt().solve(-g);
      }
      if (!xi.allFinite()) {
        every_stage_matched = false;
        break;
      }
      T = apply_twist(xi, T);
      if (xi.tail<3>().norm() < options.min_update_m * level.scale &&
          xi.head<3>().norm() < options.min_update_rad * level.scale)
        break;
    }
  }
  result.T_camera_model = T;
  result.converged = every_stage_matched;
  measure_quality(model, pyramid.level(0), projector, T, options, scratch, result);
  return result;
}

bool better(const RegistrationResult& a, const RegistrationResult& b) {
  if (a.converged != b.converged) return a.converged;
  return a.inlier_fraction > b.inlier_fraction;
}

int pyramid_levels(const IcpOptions& options) {
  int levels = 1;
  for (const IcpStage& s : options.stages) {
    if (s.pyramid_level < 0) {
      throw std::invalid_argument("align_projective_icp: pyramid_level < 0");
    }
    levels = std::max(levels, s.pyramid_level + 1);
  }
  return levels;
}

RegistrationResult align_impl(const IcpModel& model, const ScenePyramid& pyramid,
                              const Projector& projector, const Eigen::Isometry3d& guess,
                              const IcpOptions& options, Scratch& scratch) {
  RegistrationResult best = run_schedule(model, pyramid, projector, guess, options, scratch);
  int iterations = best.iterations, hypotheses = 1;
  if (best.inlier_fraction < options.retry_below_inlier_fraction) {
    for (int axis = 0; axis < 6; ++axis) {
      Eigen::Isometry3d hypothesis = guess;
      hypothesis.translation()[axis / 2] += (axis % 2 ? -1.0 : 1.0) * options.hypothesis_offset_m;
      RegistrationResult r = run_schedule(model, pyramid, projector, hypothesis, options, scratch);
      iterations += r.iterations;
      ++hypotheses;
      if (better(r, best)) best = r;
      if (best.inlier_fraction >= options.retry_below_inlier_fraction) break;
    }
  }
  best.iterations = iterations;
  best.hypotheses = hypotheses;
  return best;
}

}  // namespace

RegistrationResult align_projective_icp(const IcpModel& model, const OrganizedCloud& scene,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        const IcpOptions& options) {
  const auto started = Clock::now();
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, pyramid_levels(options), *scratch);
  RegistrationResult result =
      align_impl(model, pyramid, Projector(scene), T_camera_model_guess, options, *scratch);
  result.scene_points = scene.valid_count();
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

RegistrationResult align_projective_icp(const IcpModel& model, const DepthFrame& frame,
                                        const Eigen::Vector3d& depth_to_color_m,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        double crop_margin_m, const IcpOptions& options) {
  const auto started = Clock::now();
  detail::check_frame(frame);
  const detail::SphereCrop crop =
      detail::sphere_crop(frame, depth_to_color_m, T_camera_model_guess.translation(),
                          model.bounding_radius_m() + crop_margin_m);
  Scratch::Lease scratch;
  const ScenePyramid pyramid(frame, crop, pyramid_levels(options), *scratch);
  RegistrationResult result =
      align_impl(model, pyramid, Projector(frame.intrinsics, crop.depth_to_color_m),
                 T_camera_model_guess, options, *scratch);
  result.scene_points = pyramid.level0_valid();
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

RegistrationResult evaluate_alignment(const IcpModel& model, const OrganizedCloud& scene,
                                      const Eigen::Isometry3d& T_camera_model,
                                      const IcpOptions& options) {
  const auto started = Clock::now();
  RegistrationResult result;
  result.T_camera_model = T_camera_model;
  result.scene_points = scene.valid_count();
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, 1, *scratch);
  measure_quality(model, pyramid.level(0), Projector(scene), T_camera_model, options, *scratch,
                  result);
  result.converged = true;
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

PoseSpread pose_spread(const IcpModel& model, const OrganizedCloud& scene,
                       const Eigen::Isometry3d& T_camera_model,
                       const std::vector<Eigen::Vector3d>& points_model, double block_m,
                       const IcpOptions& options) {
  if (!(block_m > 0.0)) throw std::invalid_argument("pose_spread: block_m must be > 0");
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  struct Block {
    Matrix6 H = Matrix6::Zero();
    Vector6 g = Vector6::Zero();
    std::size_t matches = 0;
  };
  // The linearised point-to-plane problem at the pose, per block of the model: a residual r
  // moves by (p x n) . w + n . t under a small turn w and shift t.
  std::map<std::array<int, 3>, Block> blocks;
  Block all;
  const Projector projector(scene);
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, 1, *scratch);
  visit_inliers(model, pyramid.level(0), projector, T_camera_model, options, model.size(), *scratch,
                [&](std::size_t k, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                    const Eigen::Vector3f& q) {
                  Vector6 J;
                  J.head<3>() = p.cast<double>().cross(n.cast<double>());
                  J.tail<3>() = n.cast<double>();
                  const double r = n.cast<double>().dot((p - q).cast<double>());
                  const Eigen::Vector3f& m = model.points()[k];
                  const std::array<int, 3> key = {static_cast<int>(std::floor(m.x() / block_m)),
                                                  static_cast<int>(std::floor(m.y() / block_m)),
                                                  static_cast<int>(std::floor(m.z() / block_m))};
                  for (Block* b : {&blocks[key], &all}) {
                    b->H += J * J.transpose();
                    b->g += J * r;
                    ++b->matches;
                  }
                });
  PoseSpread out;
  out.matches = all.matches;
  // Blocks with a handful of points say little and their leave-one-out fits are nearly the full
  // one's: they stay in the sums but are not left out on their own.
  constexpr std::size_t kMinBlockMatches = 20;
  std::vector<const Block*> counted;
  for (const auto& [key, b] : blocks) {
    if (b.matches >= kMinBlockMatches) counted.push_back(&b);
  }
  out.blocks = static_cast<int>(counted.size());
  if (counted.size() < 4) return out;
  // Directions the whole fit hardly constrains (a flat face's slide along itself) are left to
  // other checks: every solve is regularised by a small share of the largest curvature.
  const double damping = 1e-6 * all.H.trace();
  std::vector<std::vector<Eigen::Vector3d>> moved(points_model.size());
  for (const Block* b : counted) {
    const Matrix6 H = all.H - b->H + damping * Matrix6::Identity();
    const Vector6 step = -H.ldlt().solve(all.g - b->g);
    const Eigen::Vector3d w = step.head<3>(), t = step.tail<3>();
    for (std::size_t i = 0; i < points_model.size(); ++i) {
      const Eigen::Vector3d m = T_camera_model * points_model[i];
      moved[i].push_back(w.cross(m) + t);
    }
  }
  const double K = static_cast<double>(counted.size());
  for (const auto& d : moved) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& v : d) mean += v / K;
    double sum_sq = 0.0;
    for (const auto& v : d) sum_sq += (v - mean).squaredNorm();
    out.model_point_mm = std::max(out.model_point_mm, 1e3 * std::sqrt((K - 1.0) / K * sum_sq));
  }
  return out;
}

}  // namespace projtour
