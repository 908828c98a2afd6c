// The depth drivers a real run reads: OpenNI2 (depth and colour, on OpenNI2's Dummy device) and
// mrpt_sensor's rawlog_depth on a real recorded frame, loaded as plugins the way the executor
// loads them. The steps they feed are tested in tests/plugins/steps/test_capture_align.cpp.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <chrono>
#include <filesystem>
#include <random>
#include <thread>

#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/perception/registration.hpp"
#include "projtour_test/loaded_plugins.hpp"
#include "projtour_test/rendered_scenes.hpp"
#include "projtour_test/run_rig.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

// One registry for the whole suite: plugins stay loaded, as in a run.
host::PluginRegistry& registry() {
  return test::loaded_plugins({"openni2", "mrpt_sensor"});
}

Params params_of(const std::string& kind, const std::map<std::string, ParamValue>& values = {}) {
  return test::params_with(registry(), kind, values);
}

// The real OpenNI2 path, on OpenNI2's Dummy device (320x240 depth, no hardware).
TEST(OpenNi2, DummyDeviceStreamsFramesWithIntrinsicsAndIncreasingTimestamps) {
  const test::RunRig rig{test::RunRig::RunDir::none};
  auto driver = registry().create_driver(
      "openni2", params_of("openni2", {{"uri", std::string("Dummy")}}), rig.run);
  auto* camera = dynamic_cast<DepthCameraDriver*>(driver.get());
  ASSERT_NE(camera, nullptr);
  std::vector<DepthFrame> frames;
  double t_s = 10.0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (frames.size() < 3 && std::chrono::steady_clock::now() < deadline) {
    camera->update(t_s += 0.05);
    if (auto f = camera->grab()) frames.push_back(std::move(*f));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(frames.size(), 3u);
  const double fx = 160.0 / std::tan(deg_to_rad(58.5) / 2.0);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const DepthFrame& f = frames[i];
    EXPECT_EQ(f.width, 320);
    EXPECT_EQ(f.height, 240);
    EXPECT_EQ(f.depth_mm.size(), 320u * 240u);
    EXPECT_EQ(f.intrinsics.width, 320);
    EXPECT_NEAR(f.intrinsics.fx, fx, 1e-9);
    EXPECT_NEAR(f.intrinsics.cx, 159.5, 1e-9);
    EXPECT_NEAR(f.intrinsics.cy, 119.5, 1e-9);
    EXPECT_GT(f.valid_count(), 0u);
    EXPECT_GE(f.t_s, 10.0);
    if (i > 0) {
      EXPECT_GT(f.t_s, frames[i - 1].t_s);
      EXPECT_GT(f.sequence, frames[i - 1].sequence);
    }
  }
  // The organized cloud of a Dummy frame: its readings become points at their depth.
  const perception::OrganizedCloud cloud = perception::organized_cloud(frames[0]);
  EXPECT_EQ(cloud.valid_count(), frames[0].valid_count());
}

// Real recorded depth: MRPT's tests_rgbd.rawlog holds one OpenNI2 frame of an office (a wall, a
// bookshelf, a briefcase). It comes through the rawlog_depth driver as a live camera's would; the
// wall's plane fits it to the sensor's noise; and a model cut from the frame itself registers
// back onto it from a 5 cm / 5 degree guess.
TEST(RawlogDepth, ARealOpenNi2FrameThroughTheCapturePath) {
  const fs::path rawlog = "/usr/share/mrpt/datasets/tests_rgbd.rawlog";
  ASSERT_TRUE(fs::exists(rawlog)) << "mrpt-common's datasets are installed by the build";
  const test::RunRig rig{test::RunRig::RunDir::none};
  auto driver = registry().create_driver(
      "rawlog_depth", params_of("rawlog_depth", {{"file", rawlog.string()}, {"loop", false}}),
      rig.run);
  auto* camera = dynamic_cast<DepthCameraDriver*>(driver.get());
  ASSERT_NE(camera, nullptr);
  camera->update(3.0);
  const auto frame = camera->grab();
  ASSERT_TRUE(frame);
  camera->update(4.0);
  EXPECT_FALSE(camera->grab()) << "one frame, no loop";
  EXPECT_EQ(frame->t_s, 3.0);
  EXPECT_GT(frame->intrinsics.fx, 400.0);
  EXPECT_EQ(frame->depth_mm.size(), static_cast<std::size_t>(frame->width) * frame->height);
  const double valid = static_cast<double>(frame->valid_count()) / frame->depth_mm.size();
  EXPECT_GT(valid, 0.5);

  // The dominant plane (the wall), by RANSAC over the frame's points, then least squares.
  const perception::OrganizedCloud cloud =
      perception::organized_cloud(*frame, Eigen::Vector3d::Zero(), 0.3, 5.0);
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : cloud.points) {
    if (perception::OrganizedCloud::valid(p)) points.push_back(p.cast<double>());
  }
  ASSERT_GT(points.size(), 10000u);
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
  Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ();
  double best_d = 0.0;
  std::size_t best_count = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d a = points[pick(rng)], b = points[pick(rng)], c = points[pick(rng)];
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    const Eigen::Vector3d u = n.normalized();
    std::size_t count = 0;
    for (std::size_t i = 0; i < points.size(); i += 7)
      count += std::abs(u.dot(points[i] - a)) < 0.02;
    if (count > best_count) best_count = count, best_n = u, best_d = u.dot(a);
  }
  std::vector<Eigen::Vector3d> wall;
  for (const auto& p : points) {
    if (std::abs(best_n.dot(p) - best_d) < 0.02) wall.push_back(p);
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : wall) centroid += p / static_cast<double>(wall.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : wall) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  const Eigen::Vector3d normal = eig.eigenvectors().col(0);
  double sum_sq = 0.0;
  for (const auto& p : wall) sum_sq += std::pow(normal.dot(p - centroid), 2);
  const double residual_mm = 1000.0 * std::sqrt(sum_sq / wall.size());
  std::printf(
      "tests_rgbd.rawlog: %dx%d, %.0f %% valid; the wall: %zu points at %.2f m, plane "
      "residual %.1f mm rms\n",
      frame->width, frame->height, 100.0 * valid, wall.size(), centroid.z(), residual_mm);
  EXPECT_GT(wall.size(), points.size() / 5);
  // Kinect v1 depth noise is about 1.4e-3 z^2 (7 mm at 2.3 m); a flat wall within twice that.
  EXPECT_LT(residual_mm, 2.0 * 1.4 * centroid.z() * centroid.z());

  // A model cut from the frame (what is not the wall, within 0.5 m of its middle, with normals
  // from the image's neighbours) registered back from a 5 cm / 5 degree guess.
  ModelCloud model;
  Eigen::Vector3d middle = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> kept;
  for (int j = 2; j + 2 < cloud.height; j += 2) {
    for (int i = 2; i + 2 < cloud.width; i += 2) {
      const Eigen::Vector3f& p = cloud.at(i, j);
      const Eigen::Vector3f &l = cloud.at(i - 2, j), &r = cloud.at(i + 2, j);
      const Eigen::Vector3f &u = cloud.at(i, j - 2), &d = cloud.at(i, j + 2);
      if (!perception::OrganizedCloud::valid(p) || !perception::OrganizedCloud::valid(l) ||
          !perception::OrganizedCloud::valid(r) || !perception::OrganizedCloud::valid(u) ||
          !perception::OrganizedCloud::valid(d)) {
        continue;
      }
      if (std::abs(best_n.dot(p.cast<double>()) - best_d) < 0.03) continue;  // the wall
      Eigen::Vector3f n = (r - l).cross(d - u);
      if (n.norm() < 1e-9f || (r - l).norm() > 0.05f || (d - u).norm() > 0.05f) continue;
      n.normalize();
      if (n.dot(p) > 0.0f) n = -n;  // toward the camera
      model.points.push_back(p);
      model.normals.push_back(n);
      middle += p.cast<double>();
    }
  }
  ASSERT_GT(model.points.size(), 2000u);
  middle /= static_cast<double>(model.points.size());
  ModelCloud cut;
  for (std::size_t k = 0; k < model.points.size(); ++k) {
    const Eigen::Vector3f q = model.points[k] - middle.cast<float>();
    if (q.norm() > 0.5f) continue;
    cut.points.push_back(q);
    cut.normals.push_back(model.normals[k]);
    cut.bounding_radius_m = std::max(cut.bounding_radius_m, q.norm());
  }
  ASSERT_GT(cut.points.size(), 1000u);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.translation() = middle;
  const perception::IcpModel icp_model(cut);
  std::mt19937 guesses(11);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d guess = test::perturb(truth, 0.05, deg_to_rad(5.0), guesses);
    const perception::RegistrationResult r =
        perception::align_projective_icp(icp_model, *frame, Eigen::Vector3d::Zero(), guess, 0.1);
    const double mm = 1000.0 * translation_distance_m(r.T_camera_model, truth);
    const double deg = rad_to_deg(rotation_angle_rad(r.T_camera_model, truth));
    std::printf("  from 5 cm / 5 deg: %.2f mm, %.3f deg, inlier fraction %.2f, %.2f ms\n", mm, deg,
                r.inlier_fraction, r.time_ms);
    EXPECT_TRUE(r.converged);
    EXPECT_LT(mm, 2.0) << trial;
    EXPECT_LT(deg, 0.2) << trial;
  }
}

TEST(OpenNi2, NonexistentUriIsAClearError) {
  const test::RunRig rig{test::RunRig::RunDir::none};
  try {
    registry().create_driver(
        "openni2", params_of("openni2", {{"uri", std::string("/nonexistent/tour.oni")}}), rig.run);
    FAIL() << "opened a nonexistent device";
  } catch (const host::PluginError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cannot open"), std::string::npos) << what;
    EXPECT_NE(what.find("/nonexistent/tour.oni"), std::string::npos) << what;
  }
}

// The colour kind on the Dummy device (320x240 RGB888, a picture with pure blue pixels and no
// pure red ones, so a channel swap shows).
std::vector<ColourFrame> grab_colour(ColourCameraDriver& camera, std::size_t count, double& t_s) {
  std::vector<ColourFrame> frames;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (frames.size() < count && std::chrono::steady_clock::now() < deadline) {
    camera.update(t_s += 0.05);
    if (auto f = camera.grab()) frames.push_back(std::move(*f));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return frames;
}

std::shared_ptr<Driver> dummy_colour(const test::RunRig& rig) {
  return registry().create_driver(
      "openni2_colour", params_of("openni2_colour", {{"uri", std::string("Dummy")}}), rig.run);
}

TEST(OpenNi2Colour, DummyDeviceStreamsBgrFramesWithTheRobotFilesIntrinsics) {
  test::RunRig rig{test::RunRig::RunDir::none};
  PinholeModel& file = rig.mission.robot.camera.colour.intrinsics;
  file = {320, 240, 262.0, 263.0, 160.5, 119.0, {0.2, -0.5, 0.001, 0.002, 0.7}};
  auto driver = dummy_colour(rig);
  auto* camera = dynamic_cast<ColourCameraDriver*>(driver.get());
  ASSERT_NE(camera, nullptr);
  double t_s = 10.0;
  const std::vector<ColourFrame> frames = grab_colour(*camera, 3, t_s);
  ASSERT_EQ(frames.size(), 3u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ColourFrame& f = frames[i];
    EXPECT_EQ(f.width, 320);
    EXPECT_EQ(f.height, 240);
    EXPECT_EQ(f.bgr.size(), 320u * 240u * 3u);
    EXPECT_EQ(f.intrinsics.width, 320);
    EXPECT_DOUBLE_EQ(f.intrinsics.fx, 262.0);
    EXPECT_DOUBLE_EQ(f.intrinsics.fy, 263.0);
    EXPECT_DOUBLE_EQ(f.intrinsics.cx, 160.5);
    EXPECT_DOUBLE_EQ(f.intrinsics.cy, 119.0);
    EXPECT_EQ(f.intrinsics.distortion, file.distortion);
    EXPECT_DOUBLE_EQ(f.exposure_ms, 0.0);  // automatic
    EXPECT_GE(f.t_s, 10.0);
    if (i > 0) {
      EXPECT_GT(f.t_s, frames[i - 1].t_s);
      EXPECT_GT(f.sequence, frames[i - 1].sequence);
    }
    std::size_t blue = 0, red = 0;
    for (int v = 0; v < f.height; ++v) {
      for (int u = 0; u < f.width; ++u) {
        const std::uint8_t* p = f.pixel(u, v);
        blue += p[0] == 255 && p[1] == 0 && p[2] == 0;
        red += p[0] == 0 && p[1] == 0 && p[2] == 255;
      }
    }
    EXPECT_GT(blue, 0u) << "RGB888 (0, 0, 255) must arrive as BGR (255, 0, 0)";
    EXPECT_EQ(red, 0u);
  }
}

// The robot file's colour camera is the Kinect's 640x480; the Dummy streams half of it: the
// same lens on a binned sensor.
TEST(OpenNi2Colour, IntrinsicsScaleToTheStreamedSize) {
  const test::RunRig rig{test::RunRig::RunDir::none};
  auto driver = dummy_colour(rig);
  auto* camera = dynamic_cast<ColourCameraDriver*>(driver.get());
  ASSERT_NE(camera, nullptr);
  double t_s = 0.0;
  const std::vector<ColourFrame> frames = grab_colour(*camera, 1, t_s);
  ASSERT_EQ(frames.size(), 1u);
  const PinholeModel& k = frames[0].intrinsics;
  const PinholeModel kinect = ColourCameraSpec{}.intrinsics;
  EXPECT_EQ(k.width, 320);
  EXPECT_EQ(k.height, 240);
  EXPECT_DOUBLE_EQ(k.fx, kinect.fx / 2);
  EXPECT_DOUBLE_EQ(k.fy, kinect.fy / 2);
  EXPECT_DOUBLE_EQ(k.cx, 159.5);
  EXPECT_DOUBLE_EQ(k.cy, 119.5);
  EXPECT_EQ(k.distortion, kinect.distortion);
  EXPECT_TRUE(rig.log.messages(LogLevel::warning).empty());
}

// The Dummy has no camera settings: one warning however often the exposure is set, and the
// frames keep coming.
TEST(OpenNi2Colour, ExposureOnADeviceWithoutSettingsWarnsOnceAndKeepsStreaming) {
  test::RunRig rig{test::RunRig::RunDir::none};
  rig.log.set_echo(LogLevel::error);
  auto driver = dummy_colour(rig);
  auto* camera = dynamic_cast<ColourCameraDriver*>(driver.get());
  ASSERT_NE(camera, nullptr);
  camera->set_exposure_ms(20.0);
  camera->set_exposure_ms(0.0);
  camera->set_exposure_ms(30.0);
  const std::vector<std::string> warnings = rig.log.messages(LogLevel::warning);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("openni2_colour"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("exposure"), std::string::npos) << warnings[0];
  double t_s = 0.0;
  const std::vector<ColourFrame> frames = grab_colour(*camera, 2, t_s);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_DOUBLE_EQ(frames[1].exposure_ms, 0.0);  // the device's own, not reported
  EXPECT_THROW(camera->set_exposure_ms(-1.0), std::invalid_argument);
  // The unit of the device's setting is checked when the mission loads.
  EXPECT_NE(registry().validate_params("openni2_colour",
                                       params_of("openni2_colour", {{"exposure_unit_ms", 0.0}})),
            "");
  EXPECT_EQ(registry().validate_params("openni2_colour", params_of("openni2_colour")), "");
}

// Depth and colour of one device: one openni::Device, so one device clock. Once depth has
// anchored it to mission time, colour frames follow device time however late they are polled.
TEST(OpenNi2Colour, RunsBesideTheDepthKindOnOneDevice) {
  const test::RunRig rig{test::RunRig::RunDir::none};
  auto depth_driver = registry().create_driver(
      "openni2", params_of("openni2", {{"uri", std::string("Dummy")}}), rig.run);
  auto colour_driver = dummy_colour(rig);
  auto* depth = dynamic_cast<DepthCameraDriver*>(depth_driver.get());
  auto* colour = dynamic_cast<ColourCameraDriver*>(colour_driver.get());
  ASSERT_NE(depth, nullptr);
  ASSERT_NE(colour, nullptr);

  std::vector<DepthFrame> depth_frames;
  std::vector<ColourFrame> colour_frames;
  double t_s = 10.0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((depth_frames.size() < 3 || colour_frames.size() < 3) &&
         std::chrono::steady_clock::now() < deadline) {
    t_s += 0.05;
    depth->update(t_s);
    colour->update(t_s);
    if (auto f = depth->grab()) depth_frames.push_back(std::move(*f));
    if (auto f = colour->grab()) colour_frames.push_back(std::move(*f));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_GE(depth_frames.size(), 3u);
  ASSERT_GE(colour_frames.size(), 3u);
  for (std::size_t i = 1; i < colour_frames.size(); ++i) {
    EXPECT_GT(colour_frames[i].t_s, colour_frames[i - 1].t_s);
    EXPECT_GT(colour_frames[i].sequence, colour_frames[i - 1].sequence);
    EXPECT_GT(depth_frames[std::min(i, depth_frames.size() - 1)].t_s, depth_frames[0].t_s);
  }
  EXPECT_EQ(colour_frames.back().width, 320);
  EXPECT_GT(depth_frames.back().valid_count(), 0u);

  // Mission time jumps a minute ahead of the device: the next colour frame is stamped by the
  // shared clock, a fraction of a second after the last, not at the late poll.
  const double last_s = colour_frames.back().t_s;
  double late_s = t_s + 60.0;
  const std::vector<ColourFrame> late = grab_colour(*colour, 1, late_s);
  ASSERT_EQ(late.size(), 1u);
  EXPECT_GT(late[0].t_s, last_s);
  EXPECT_LT(late[0].t_s, last_s + 5.0);

  // The device outlives either kind: colour keeps streaming once depth is gone, and depth
  // opens again beside it.
  depth_driver.reset();
  double after_s = late_s;
  EXPECT_EQ(grab_colour(*colour, 2, after_s).size(), 2u);
  depth_driver = registry().create_driver(
      "openni2", params_of("openni2", {{"uri", std::string("Dummy")}}), rig.run);
  depth = dynamic_cast<DepthCameraDriver*>(depth_driver.get());
  ASSERT_NE(depth, nullptr);
  std::optional<DepthFrame> again;
  for (int i = 0; i < 100 && !again; ++i) {
    depth->update(after_s += 0.05);
    again = depth->grab();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(again);
  EXPECT_EQ(again->width, 320);
}

TEST(OpenNi2Colour, NonexistentUriIsAClearError) {
  const test::RunRig rig{test::RunRig::RunDir::none};
  try {
    registry().create_driver(
        "openni2_colour",
        params_of("openni2_colour", {{"uri", std::string("/nonexistent/tour.oni")}}), rig.run);
    FAIL() << "opened a nonexistent device";
  } catch (const host::PluginError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("openni2_colour: cannot open"), std::string::npos) << what;
    EXPECT_NE(what.find("/nonexistent/tour.oni"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace projtour
