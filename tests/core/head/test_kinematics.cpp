#include <gtest/gtest.h>

#include <random>

#include "projtour/contract/geometry.hpp"
#include "projtour/head/kinematics.hpp"

using namespace projtour;

namespace {

// A head with a nonzero offset at every joint and mount, like a real Ubiquitous Display head.
head::HeadKinematics offset_head(PanTiltSpec* spec_out = nullptr) {
  PanTiltSpec pt;
  pt.T_base_pan0 = isometry_from_xyz_rpy(0.05, -0.03, 1.20, 0.0, 0.0, deg_to_rad(4.0));
  pt.T_pan_tilt0 = isometry_from_xyz_rpy(0.04, 0.06, 0.15, 0.0, deg_to_rad(3.0), deg_to_rad(-2.0));
  MountSpec camera;
  camera.link = Link::pan;
  camera.T_link_body = isometry_from_xyz_rpy(0.08, 0.02, 0.25, 0.0, deg_to_rad(10.0), 0.0);
  MountSpec projector;
  projector.link = Link::tilt;
  projector.T_link_body =
      isometry_from_xyz_rpy(0.12, -0.09, 0.07, deg_to_rad(1.5), deg_to_rad(-5.0), 0.0);
  if (spec_out != nullptr) *spec_out = pt;
  return head::HeadKinematics(pt, camera, projector);
}

double distance_to_optical_axis_m(const head::HeadKinematics& k, const JointAngles& q,
                                  const Eigen::Vector3d& p_base, double* along_m = nullptr) {
  const Eigen::Vector3d p = k.T_base_projector(q).inverse() * p_base;  // optical frame
  if (along_m != nullptr) *along_m = p.z();
  return std::hypot(p.x(), p.y());
}

}  // namespace

TEST(Kinematics, TiltPositiveLooksDown) {
  PanTiltSpec pt;
  MountSpec m;
  m.link = Link::tilt;
  const head::HeadKinematics k(pt, m, m);
  const Eigen::Vector3d forward =
      k.T_base_projector({0.0, deg_to_rad(30)}).linear() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(forward.z(), -0.4);
  const Eigen::Vector3d left =
      k.T_base_projector({deg_to_rad(90), 0.0}).linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(left.y(), 1.0, 1e-12);
}

TEST(Kinematics, TiltEntersProjectorCameraTransformOnlyWhenLinksDiffer) {
  const head::HeadKinematics k = offset_head();
  const Eigen::Isometry3d a = k.T_projector_camera({0.3, 0.0});
  const Eigen::Isometry3d b = k.T_projector_camera({-0.7, 0.0});
  const Eigen::Isometry3d c = k.T_projector_camera({0.3, 0.4});
  EXPECT_LT(translation_distance_m(a, b), 1e-12);  // pan moves both alike
  EXPECT_GT(rotation_angle_rad(a, c), 0.39);       // tilt moves only the projector
  // Composes: camera -> base -> projector.
  const JointAngles q{0.2, -0.1};
  EXPECT_TRUE((k.T_base_projector(q) * k.T_projector_camera(q)).isApprox(k.T_base_camera(q)));
}

TEST(Kinematics, InverseKinematicsPutsThousandRandomPointsOnTheOpticalAxis) {
  PanTiltSpec pt;
  const head::HeadKinematics k = offset_head(&pt);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pan(deg_to_rad(pt.pan_min_deg) + 0.01,
                                             deg_to_rad(pt.pan_max_deg) - 0.01);
  std::uniform_real_distribution<double> tilt(deg_to_rad(pt.tilt_min_deg) + 0.01,
                                              deg_to_rad(pt.tilt_max_deg) - 0.01);
  std::uniform_real_distribution<double> range(0.5, 8.0);
  double worst_m = 0.0;
  int solved = 0;
  for (int i = 0; i < 1000; ++i) {
    // Reachable by construction: a point on the axis of a random in-limits pose.
    const JointAngles q_true{pan(rng), tilt(rng)};
    const Eigen::Isometry3d T = k.T_base_projector(q_true);
    const Eigen::Vector3d p = T * Eigen::Vector3d(0, 0, range(rng));
    std::string why;
    const auto q = k.aim_projector_at(p, &why);
    ASSERT_TRUE(q) << "point " << i << ": " << why;
    EXPECT_TRUE(k.within_limits(*q));
    double along_m = 0.0;
    worst_m = std::max(worst_m, distance_to_optical_axis_m(k, *q, p, &along_m));
    EXPECT_GT(along_m, 0.0) << "point behind the projector";
    ++solved;
  }
  EXPECT_EQ(solved, 1000);
  EXPECT_LT(worst_m, 1e-5) << "worst distance to the optical axis (m)";
  std::printf("[ figures  ] IK over 1000 points: max distance to optical axis %.3g mm\n",
              worst_m * 1e3);
}

TEST(Kinematics, InverseKinematicsBeatsTheNaiveDirection) {
  PanTiltSpec pt;
  const head::HeadKinematics k = offset_head(&pt);
  const Eigen::Vector3d p(2.0, 0.5, 0.8);
  const auto q = k.aim_projector_at(p);
  ASSERT_TRUE(q);
  EXPECT_LT(distance_to_optical_axis_m(k, *q, p), 1e-9);
  // Pointing the pan-tilt origin at the point ignores the offsets and misses by centimetres.
  const Eigen::Vector3d p0 = pt.T_base_pan0.inverse() * p;
  const JointAngles naive{std::atan2(p0.y(), p0.x()), -std::atan2(p0.z(), p0.head<2>().norm())};
  EXPECT_GT(distance_to_optical_axis_m(k, naive, p), 0.02);
}

TEST(Kinematics, OutOfReachPointsReportTheReason) {
  const head::HeadKinematics k = offset_head();
  std::string why;
  // Straight up: tilt would be far below -30 deg.
  EXPECT_FALSE(k.aim_projector_at(Eigen::Vector3d(0.5, 0.0, 5.0), &why));
  EXPECT_NE(why.find("tilt"), std::string::npos) << why;
  // Straight down at the robot's feet: more than 60 deg down.
  why.clear();
  EXPECT_FALSE(k.aim_projector_at(Eigen::Vector3d(0.3, 0.05, 0.0), &why));
  EXPECT_NE(why.find("tilt"), std::string::npos) << why;
  // Behind: pan near 180 deg, beyond the +-170 deg limits.
  why.clear();
  EXPECT_FALSE(k.aim_projector_at(Eigen::Vector3d(-3.0, 0.0, 1.3), &why));
  EXPECT_NE(why.find("pan"), std::string::npos) << why;
  // On the pan axis: closer than the optical axis' lateral offset.
  why.clear();
  EXPECT_FALSE(k.aim_projector_at(Eigen::Vector3d(0.05, -0.03, 3.0), &why));
  EXPECT_NE(why.find("lateral offset"), std::string::npos) << why;
}

TEST(Kinematics, WithinLimits) {
  const head::HeadKinematics k = offset_head();
  EXPECT_TRUE(k.within_limits({deg_to_rad(170), deg_to_rad(-30)}));
  EXPECT_FALSE(k.within_limits({deg_to_rad(171), 0.0}));
  EXPECT_FALSE(k.within_limits({0.0, deg_to_rad(61)}));
}
