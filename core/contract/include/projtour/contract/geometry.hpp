#pragma once
// Poses and transforms. Every 3-D transform is an Eigen::Isometry3d named T_<to>_<from>.
#include <Eigen/Geometry>
#include <cmath>

namespace projtour {

constexpr double kPi = 3.14159265358979323846;
inline double deg_to_rad(double deg) {
  return deg * kPi / 180.0;
}
inline double rad_to_deg(double rad) {
  return rad * 180.0 / kPi;
}
// Wraps to (-pi, pi].
double wrap_angle_rad(double a);

// A pose on the floor plane of the map.
struct Pose2D {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

// Pose estimate with its 3x3 covariance over (x, y, yaw).
struct PoseEstimate2D {
  Pose2D mean;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  double t_s = 0.0;
};

// Intrinsic Z-Y-X (yaw, then pitch, then roll) rotation, as ROS and the mission files use.
Eigen::Isometry3d isometry_from_xyz_rpy(double x_m, double y_m, double z_m, double roll_rad,
                                        double pitch_rad, double yaw_rad);
Eigen::Isometry3d isometry_from_pose2d(const Pose2D& pose);
// Drops z, roll and pitch.
Pose2D pose2d_from_isometry(const Eigen::Isometry3d& T);

// Translation (m) and rotation angle (rad) between two transforms.
double translation_distance_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
double rotation_angle_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

// The camera/projector optical frame (OpenCV: z forward, x right, y down) expressed in the
// device body frame (x forward, y left, z up), which is what robot files give mount poses in.
Eigen::Isometry3d T_body_optical();

}  // namespace projtour
