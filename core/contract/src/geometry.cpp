#include "projtour/contract/geometry.hpp"

namespace projtour {

double wrap_angle_rad(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

Eigen::Isometry3d isometry_from_xyz_rpy(double x_m, double y_m, double z_m, double roll_rad,
                                        double pitch_rad, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return T;
}

Eigen::Isometry3d isometry_from_pose2d(const Pose2D& pose) {
  return isometry_from_xyz_rpy(pose.x_m, pose.y_m, 0.0, 0.0, 0.0, pose.yaw_rad);
}

Pose2D pose2d_from_isometry(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d x_axis = T.linear().col(0);
  return Pose2D{T.translation().x(), T.translation().y(), std::atan2(x_axis.y(), x_axis.x())};
}

double translation_distance_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

double rotation_angle_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

Eigen::Isometry3d T_body_optical() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Columns: optical x (right) = -body y, optical y (down) = -body z, optical z (fwd) = body x.
  T.linear() << 0, 0, 1,  //
      -1, 0, 0,           //
      0, -1, 0;
  return T;
}

}  // namespace projtour
