#pragma once
// The projective data association: the model moved into the camera and projected, the scene
// normals, and the nearest scene point in a window of the pyramid level.
// Included only by registration_icp.cpp, the one translation unit of the alignment: its
// types stay in that unit's anonymous namespace, so the hot loop inlines (and the compiler
// sees every call of each helper) exactly as when it was one file.
#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "icp_scene_pyramid.hpp"
#include "icp_scratch.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour/perception/registration.hpp"
#include "vector_clones.hpp"

namespace projtour::perception {
namespace {

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

}  // namespace
}  // namespace projtour::perception
