#pragma once
// Pinhole models of the depth camera and of the projector (a projector is a camera run backwards).
#include <Eigen/Core>
#include <array>
#include <optional>

namespace projtour {

struct PinholeModel {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // OpenCV radial-tangential distortion: k1, k2, p1, p2, k3 (all zero = none).
  std::array<double, 5> distortion{0, 0, 0, 0, 0};

  bool has_distortion() const;
  // Point in the optical frame (z forward) -> pixel, distortion applied; nullopt when z <= 0.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_optical) const;
  // Pixel -> unit-depth ray (z = 1) in the optical frame, distortion removed.
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;
  bool in_image(const Eigen::Vector2d& pixel) const;
  // Horizontal throw ratio = distance / image width = fx / width.
  double throw_ratio() const { return width > 0 ? fx / width : 0.0; }
};

}  // namespace projtour
