// Four coherent rays through the BVH together. Rays of neighbouring pixels visit nearly the same
// nodes, so one node fetch and one SIMD box test serve four rays, and with a shared origin half
// of each triangle test is a scalar.
#include <cmath>
#include <limits>

#include "projtour_sim/depth_renderer.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace projtour::sim {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kStackSize = 64;
}  // namespace

void Scene::intersect4(const Eigen::Vector3f& origin, const float dir_x[4], const float dir_y[4],
                       const float dir_z[4], float t_max, RayHit hits[4]) const {
  for (int k = 0; k < 4; ++k) {
    hits[k] = RayHit();
    hits[k].t = t_max;
    if (has_floor_ && dir_z[k] != 0.0f) {
      const float t = (floor_z_m_ - origin.z()) / dir_z[k];
      if (t > 1e-6f && t < hits[k].t) {
        hits[k].t = t;
        hits[k].object_id = floor_object_;
        hits[k].normal = Eigen::Vector3f::UnitZ();
      }
    }
  }
  if (!nodes_.empty()) intersect_bvh4(origin.data(), dir_x, dir_y, dir_z, hits);
  for (int k = 0; k < 4; ++k) {
    if (!people_.empty()) {
      intersect_people(origin, Eigen::Vector3f(dir_x[k], dir_y[k], dir_z[k]), hits[k]);
    }
    if (hits[k].object_id == kNoObject) hits[k].t = kInf;
  }
}

#if defined(__SSE2__)

void Scene::intersect_bvh4(const float o[3], const float dx[4], const float dy[4],
                           const float dz[4], RayHit hits[4]) const {
  auto safe_inverse = [](float x) {
    return 1.0f / (std::fabs(x) > 1e-20f ? x : std::copysign(1e-20f, x));
  };
  alignas(16) float inv[3][4];
  for (int k = 0; k < 4; ++k) {
    inv[0][k] = safe_inverse(dx[k]);
    inv[1][k] = safe_inverse(dy[k]);
    inv[2][k] = safe_inverse(dz[k]);
  }
  const __m128 idx = _mm_load_ps(inv[0]), idy = _mm_load_ps(inv[1]), idz = _mm_load_ps(inv[2]);
  const __m128 vdx = _mm_loadu_ps(dx), vdy = _mm_loadu_ps(dy), vdz = _mm_loadu_ps(dz);
  const __m128 zero = _mm_set1_ps(-kEdgeTolerance), one = _mm_set1_ps(1.0f + kEdgeTolerance),
               eps = _mm_set1_ps(1e-6f);
  __m128 t_best = _mm_setr_ps(hits[0].t, hits[1].t, hits[2].t, hits[3].t);
  __m128i best = _mm_set1_epi32(-1);

  // Entry distance per lane into a box (infinity where missed or beyond t_best).
  auto box = [&](const Node& n) {
    const __m128 x0 = _mm_mul_ps(_mm_set1_ps(n.lo[0] - o[0]), idx);
    const __m128 x1 = _mm_mul_ps(_mm_set1_ps(n.hi[0] - o[0]), idx);
    const __m128 y0 = _mm_mul_ps(_mm_set1_ps(n.lo[1] - o[1]), idy);
    const __m128 y1 = _mm_mul_ps(_mm_set1_ps(n.hi[1] - o[1]), idy);
    const __m128 z0 = _mm_mul_ps(_mm_set1_ps(n.lo[2] - o[2]), idz);
    const __m128 z1 = _mm_mul_ps(_mm_set1_ps(n.hi[2] - o[2]), idz);
    const __m128 t_in = _mm_max_ps(_mm_max_ps(_mm_min_ps(x0, x1), _mm_min_ps(y0, y1)),
                                   _mm_max_ps(_mm_min_ps(z0, z1), zero));
    const __m128 t_out = _mm_min_ps(_mm_min_ps(_mm_max_ps(x0, x1), _mm_max_ps(y0, y1)),
                                    _mm_min_ps(_mm_max_ps(z0, z1), t_best));
    const __m128 hit = _mm_cmple_ps(t_in, t_out);
    return _mm_or_ps(_mm_and_ps(hit, t_in), _mm_andnot_ps(hit, _mm_set1_ps(kInf)));
  };
  auto lane_min = [](__m128 v) {
    v = _mm_min_ps(v, _mm_shuffle_ps(v, v, _MM_SHUFFLE(2, 3, 0, 1)));
    v = _mm_min_ps(v, _mm_shuffle_ps(v, v, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm_cvtss_f32(v);
  };

  std::int32_t stack[kStackSize];
  float stack_t[kStackSize];
  int top = 0;
  if (lane_min(box(nodes_[0])) == kInf) return;
  std::int32_t current = 0;
  while (true) {
    const Node& node = nodes_[current];
    if (node.count > 0) {
      for (std::int32_t k = node.first; k < node.first + node.count; ++k) {
        // Baldwin-Weber with the shared origin: the origin's plane distance is one scalar.
        const float* m = tris_[k].m;
        const float oz = m[8] * o[0] + m[9] * o[1] + m[10] * o[2] + m[11];
        const __m128 denom = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[8]), vdx), _mm_mul_ps(_mm_set1_ps(m[9]), vdy)),
            _mm_mul_ps(_mm_set1_ps(m[10]), vdz));
        const __m128 t = _mm_div_ps(_mm_set1_ps(-oz), denom);
        __m128 ok = _mm_and_ps(_mm_cmpgt_ps(t, eps), _mm_cmplt_ps(t, t_best));
        if (_mm_movemask_ps(ok) == 0) continue;
        const __m128 hx = _mm_add_ps(_mm_set1_ps(o[0]), _mm_mul_ps(t, vdx));
        const __m128 hy = _mm_add_ps(_mm_set1_ps(o[1]), _mm_mul_ps(t, vdy));
        const __m128 hz = _mm_add_ps(_mm_set1_ps(o[2]), _mm_mul_ps(t, vdz));
        const __m128 b1 = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[0]), hx), _mm_mul_ps(_mm_set1_ps(m[1]), hy)),
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[2]), hz), _mm_set1_ps(m[3])));
        const __m128 b2 = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[4]), hx), _mm_mul_ps(_mm_set1_ps(m[5]), hy)),
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[6]), hz), _mm_set1_ps(m[7])));
        ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpge_ps(b1, zero), _mm_cmpge_ps(b2, zero)));
        ok = _mm_and_ps(ok, _mm_cmple_ps(_mm_add_ps(b1, b2), one));
        if (_mm_movemask_ps(ok) == 0) continue;
        t_best = _mm_or_ps(_mm_and_ps(ok, t), _mm_andnot_ps(ok, t_best));
        const __m128i okm = _mm_castps_si128(ok);
        best = _mm_or_si128(_mm_and_si128(okm, _mm_set1_epi32(k)), _mm_andnot_si128(okm, best));
      }
    } else {
      std::int32_t near_child = node.first, far_child = node.first + 1;
      float t_near = lane_min(box(nodes_[near_child]));
      float t_far = lane_min(box(nodes_[far_child]));
      if (t_far < t_near) {
        std::swap(t_near, t_far);
        std::swap(near_child, far_child);
      }
      if (t_near != kInf) {
        if (t_far != kInf && top < kStackSize) {
          stack_t[top] = t_far;
          stack[top++] = far_child;
        }
        current = near_child;
        continue;
      }
    }
    // Pop the next subtree some lane may still hit before its best.
    alignas(16) float tb[4];
    _mm_store_ps(tb, t_best);
    const float t_worst = std::max(std::max(tb[0], tb[1]), std::max(tb[2], tb[3]));
    bool found = false;
    while (top > 0) {
      --top;
      if (stack_t[top] < t_worst) {
        current = stack[top];
        found = true;
        break;
      }
    }
    if (!found) break;
  }
  alignas(16) float tb[4];
  alignas(16) std::int32_t bi[4];
  _mm_store_ps(tb, t_best);
  _mm_store_si128(reinterpret_cast<__m128i*>(bi), best);
  for (int k = 0; k < 4; ++k) {
    if (bi[k] < 0) continue;
    hits[k].t = tb[k];
    hits[k].object_id = tri_object_[bi[k]];
    hits[k].normal = tri_normal_[bi[k]];
  }
}

#else

// Without SSE: four single rays.
void Scene::intersect_bvh4(const float o[3], const float dx[4], const float dy[4],
                           const float dz[4], RayHit hits[4]) const {
  for (int k = 0; k < 4; ++k) {
    const float d[3] = {dx[k], dy[k], dz[k]};
    intersect_bvh(o, d, hits[k]);
  }
}

#endif

}  // namespace projtour::sim
