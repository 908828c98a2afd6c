// PinholeModel's distortion against OpenCV's: project against cv::projectPoints and unproject
// against cv::undistortPoints, on the robot file's projector and on a strong wide-angle lens,
// so the own model (kept dependency-free for plugins) cannot drift from the convention that
// calibration tools write.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "projtour/contract/pinhole.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour/host/mission_loader.hpp"

namespace projtour {
namespace {

PinholeModel robot_projector() {
  host::Diagnostics diag;
  const auto robot = host::load_robot(PROJTOUR_SOURCE_DIR "/examples/robot/ud.yaml", diag);
  if (!robot) throw std::runtime_error(diag.format());
  return robot->projector.intrinsics;
}

// A wide-angle lens: barrel distortion two orders stronger than the projector's, tangential
// terms and k3, still monotonic out to the image corners.
PinholeModel strong_lens() {
  PinholeModel m = robot_projector();
  m.distortion = {-0.35, 0.15, 0.0012, -0.0021, -0.03};
  return m;
}

cv::Matx33d camera_matrix(const PinholeModel& m) {
  return cv::Matx33d(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1);
}

std::vector<double> distortion(const PinholeModel& m) {
  return std::vector<double>(m.distortion.begin(), m.distortion.end());
}

std::string scientific(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", v);
  return buf;
}

class PinholeAgainstOpenCv : public ::testing::TestWithParam<const char*> {
 protected:
  PinholeModel model() const {
    return std::string(GetParam()) == "robot_projector" ? robot_projector() : strong_lens();
  }
};

TEST_P(PinholeAgainstOpenCv, ProjectMatchesProjectPoints) {
  const PinholeModel m = model();
  ASSERT_TRUE(m.has_distortion());
  std::mt19937_64 rng(11);
  // Points over the whole frustum (and a little beyond the image) at 0.3 to 5 m.
  std::uniform_real_distribution<double> u(-0.1, 1.1), depth(0.3, 5.0);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 2000; ++i) {
    const double z = depth(rng);
    const double x = (u(rng) * m.width - m.cx) / m.fx, y = (u(rng) * m.height - m.cy) / m.fy;
    points.emplace_back(x * z, y * z, z);
  }
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix(m), distortion(m),
                    expected);
  double worst_px = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto pixel = m.project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    ASSERT_TRUE(pixel.has_value());
    worst_px = std::max(worst_px, (*pixel - Eigen::Vector2d(expected[i].x, expected[i].y)).norm());
  }
  EXPECT_LT(worst_px, 0.01);
  RecordProperty("worst_px", scientific(worst_px));
}

TEST_P(PinholeAgainstOpenCv, UnprojectMatchesUndistortPoints) {
  const PinholeModel m = model();
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> ux(0.0, m.width - 1.0), uy(0.0, m.height - 1.0);
  std::vector<cv::Point2d> pixels;
  for (int i = 0; i < 2000; ++i) pixels.emplace_back(ux(rng), uy(rng));
  // OpenCV's default stops after 5 iterations, short of 1e-6 on the strong lens; iterate it to
  // convergence so the comparison is of the models, not of the solvers' stopping rules.
  std::vector<cv::Point2d> expected;
  cv::undistortPoints(
      pixels, expected, camera_matrix(m), distortion(m), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-15));
  double worst_ray = 0.0, worst_round_trip_px = 0.0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector2d pixel(pixels[i].x, pixels[i].y);
    const Eigen::Vector3d ray = m.unproject(pixel);
    EXPECT_EQ(ray.z(), 1.0);
    worst_ray =
        std::max(worst_ray, (ray - Eigen::Vector3d(expected[i].x, expected[i].y, 1.0)).norm());
    const auto back = m.project(ray);
    ASSERT_TRUE(back.has_value());
    worst_round_trip_px = std::max(worst_round_trip_px, (*back - pixel).norm());
  }
  EXPECT_LT(worst_ray, 1e-6);
  EXPECT_LT(worst_round_trip_px, 1e-6);
  RecordProperty("worst_ray", scientific(worst_ray));
  RecordProperty("worst_round_trip_px", scientific(worst_round_trip_px));
}

INSTANTIATE_TEST_SUITE_P(Lenses, PinholeAgainstOpenCv,
                         ::testing::Values("robot_projector", "strong_lens"));

}  // namespace
}  // namespace projtour
