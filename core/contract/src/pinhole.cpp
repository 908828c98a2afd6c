#include "projtour/contract/pinhole.hpp"

#include <Eigen/LU>

namespace projtour {

bool PinholeModel::has_distortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

namespace {
// OpenCV's radial-tangential model on normalized coordinates.
Eigen::Vector2d distort(const std::array<double, 5>& d, const Eigen::Vector2d& n) {
  const double x = n.x(), y = n.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  return {x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x),
          y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y};
}
}  // namespace

std::optional<Eigen::Vector2d> PinholeModel::project(const Eigen::Vector3d& p_optical) const {
  if (p_optical.z() <= 0.0) return std::nullopt;
  Eigen::Vector2d n(p_optical.x() / p_optical.z(), p_optical.y() / p_optical.z());
  if (has_distortion()) n = distort(distortion, n);
  return Eigen::Vector2d(fx * n.x() + cx, fy * n.y() + cy);
}

Eigen::Vector3d PinholeModel::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d distorted((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  Eigen::Vector2d n = distorted;
  if (has_distortion()) {
    // Gauss-Newton on distort(n) = distorted with a numeric Jacobian: converges to well below
    // 1e-12 in a few steps for the mild distortion of real lenses.
    for (int iteration = 0; iteration < 20; ++iteration) {
      const Eigen::Vector2d residual = distort(distortion, n) - distorted;
      if (residual.squaredNorm() < 1e-28) break;
      constexpr double h = 1e-7;
      Eigen::Matrix2d J;
      J.col(0) = (distort(distortion, n + Eigen::Vector2d(h, 0)) - distort(distortion, n)) / h;
      J.col(1) = (distort(distortion, n + Eigen::Vector2d(0, h)) - distort(distortion, n)) / h;
      n -= J.lu().solve(residual);
    }
  }
  return Eigen::Vector3d(n.x(), n.y(), 1.0);
}

bool PinholeModel::in_image(const Eigen::Vector2d& pixel) const {
  return pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() <= width - 1.0 &&
         pixel.y() <= height - 1.0;
}

}  // namespace projtour
