#pragma once
// The Gauss-Newton step's normal equations, and the pose update it solves for.
// Included only by registration_icp.cpp, the one translation unit of the alignment: its
// types stay in that unit's anonymous namespace, so the hot loop inlines (and the compiler
// sees every call of each helper) exactly as when it was one file.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "icp_scratch.hpp"
#include "vector_clones.hpp"

namespace projtour::perception {
namespace {

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

}  // namespace
}  // namespace projtour::perception
