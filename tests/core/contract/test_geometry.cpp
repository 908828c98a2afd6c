#include <gtest/gtest.h>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/pinhole.hpp"

using namespace projtour;

TEST(Geometry, Pose2dRoundTripsThroughIsometry) {
  const Pose2D p{1.5, -2.0, deg_to_rad(135)};
  const Pose2D q = pose2d_from_isometry(isometry_from_pose2d(p));
  EXPECT_NEAR(q.x_m, 1.5, 1e-12);
  EXPECT_NEAR(q.y_m, -2.0, 1e-12);
  EXPECT_NEAR(q.yaw_rad, deg_to_rad(135), 1e-12);
}

TEST(Geometry, WrapAngleStaysInHalfOpenInterval) {
  EXPECT_NEAR(wrap_angle_rad(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-kPi / 2 - 4 * kPi), -kPi / 2, 1e-12);
}

TEST(Geometry, OpticalFrameLooksAlongBodyX) {
  const Eigen::Vector3d forward_in_body = T_body_optical() * Eigen::Vector3d(0, 0, 1);
  EXPECT_TRUE(forward_in_body.isApprox(Eigen::Vector3d(1, 0, 0)));
  const Eigen::Vector3d right_in_body = T_body_optical() * Eigen::Vector3d(1, 0, 0);
  EXPECT_TRUE(right_in_body.isApprox(Eigen::Vector3d(0, -1, 0)));
}

TEST(Pinhole, UnprojectInvertsDistortedProjection) {
  PinholeModel m;
  m.width = 1280;
  m.height = 800;
  m.fx = m.fy = 1900;
  m.cx = 640;
  m.cy = 400;
  m.distortion = {-0.12, 0.05, 0.001, -0.0015, 0.0};
  for (double x : {-0.3, 0.0, 0.25}) {
    for (double y : {-0.2, 0.1}) {
      const Eigen::Vector3d p(x, y, 1.0);
      const auto px = m.project(p);
      ASSERT_TRUE(px);
      EXPECT_LT((m.unproject(*px) - p).norm(), 1e-9);
    }
  }
  EXPECT_FALSE(m.project(Eigen::Vector3d(0, 0, -1)));
}
