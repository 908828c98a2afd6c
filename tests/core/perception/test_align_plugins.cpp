// The capture and align behaviours and the OpenNI2 driver, loaded as plugins the way the
// executor loads them, over drivers made for the test and frames from the simulator's renderer.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/perception/registration.hpp"
#include "projtour_test/run_rig.hpp"
#include "rendered_scenes.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

class FixedPanTilt : public PanTiltDriver {
 public:
  JointAngles q;
  void command(const JointAngles& angles) override { q = angles; }
  JointAngles measured() const override { return q; }
  bool reached() const override { return true; }
  void safe_stop() override {}
};

class QueuedCamera : public DepthCameraDriver {
 public:
  std::deque<DepthFrame> frames;
  bool disconnected = false;
  std::optional<DepthFrame> grab() override {
    if (disconnected) throw DriverError("USB device gone");
    if (frames.empty()) return std::nullopt;
    DepthFrame f = std::move(frames.front());
    frames.pop_front();
    return f;
  }
  void safe_stop() override {}
};

const char* const kBunny = PROJTOUR_SOURCE_DIR "/examples/models/bunny.ply";

// One registry for the whole suite: plugins stay loaded, as in a run.
PluginRegistry& registry() {
  static PluginRegistry* r = [] {
    auto* reg = new PluginRegistry;
    for (const char* name : {"capture", "align", "openni2", "mrpt_sensor"}) {
      reg->load_library(fs::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                        ("libprojtour_" + std::string(name) + ".so"));
    }
    return reg;
  }();
  return *r;
}

Params params_of(const std::string& kind, const std::map<std::string, ParamValue>& values = {}) {
  Params p = default_params(registry().require(kind).params);
  for (const auto& [name, value] : values) p.set(name, value);
  return p;
}

// A robot at the map origin with its camera 1 m up on the pan link, looking along +x, and a
// target 1 m ahead; the target truly sits a little off its nominal pose.
class PluginTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mission_.robot.pan_tilt.T_base_pan0.translation() = Eigen::Vector3d(0.1, 0.0, 1.0);
    mission_.robot.camera.mount.link = Link::tilt;
    mission_.robot.camera.depth_to_color_m = Eigen::Vector3d(0.025, 0.0, 0.0);
    TargetSpec target;
    target.id = "rabbit";
    target.model = kBunny;
    target.T_map_model = isometry_from_xyz_rpy(1.1, 0.0, 0.85, 0.0, 0.0, kPi);
    mission_.targets.push_back(target);
    pan_tilt_->q = {0.0, deg_to_rad(8.0)};

    run_.dry_run = false;
    drivers_.pan_tilt = pan_tilt_;
    drivers_.depth_camera = camera_;
    ctx_ = rig_.target_context(0);
    PoseEstimate2D loc;
    blackboard_.set(keys::kLocalization, loc);
  }

  Eigen::Isometry3d T_camera_model_true() const {
    const Eigen::Isometry3d T_map_model_true =
        mission_.targets[0].T_map_model *
        isometry_from_xyz_rpy(0.03, -0.02, 0.01, 0.02, -0.03, 0.05);
    const Eigen::Isometry3d T_map_camera =
        HeadKinematics(mission_.robot).T_base_camera(pan_tilt_->q);
    return T_map_camera.inverse() * T_map_model_true;
  }

  // A rendered frame of the true target, with the depth-colour offset undone (the renderer
  // works in the depth optical frame).
  DepthFrame rendered_frame(unsigned seed) const {
    Eigen::Isometry3d T_depth_model = T_camera_model_true();
    T_depth_model.translation() -= mission_.robot.camera.depth_to_color_m;
    const TriangleMesh mesh = load_mesh(kBunny);
    return test::render_on_floor(mesh, T_depth_model, true, seed);
  }

  // A frame as capture publishes it: stamped with the joints and the base estimate.
  CapturedFrame captured(DepthFrame frame) const {
    CapturedFrame c;
    c.frame = std::move(frame);
    c.joints = pan_tilt_->q;
    c.base_estimate = *blackboard_.find(keys::kLocalization);
    return c;
  }
  const AlignResult& aligned() const {
    const AlignResult* r = blackboard_.find(keys::kAlign);
    if (r == nullptr) throw std::runtime_error("align published no result");
    return *r;
  }

  // start, tick until an outcome (advancing the clock 1/30 s per tick), stop.
  Outcome run_behaviour(Behaviour& b, int max_ticks = 1000) {
    Params p;
    ctx_.params = &p;
    b.start(ctx_);
    for (int i = 0; i < max_ticks; ++i) {
      if (auto o = b.tick(ctx_)) {
        b.stop(ctx_);
        return *o;
      }
      clock_.advance(1.0 / 30.0);
    }
    b.stop(ctx_);
    return {"(still running)", ""};
  }

  test::RunRig rig_;
  MissionSpec& mission_ = rig_.mission;
  DriverSet& drivers_ = rig_.drivers;
  std::shared_ptr<FixedPanTilt> pan_tilt_ = std::make_shared<FixedPanTilt>();
  std::shared_ptr<QueuedCamera> camera_ = std::make_shared<QueuedCamera>();
  Blackboard& blackboard_ = rig_.blackboard;
  SteppedClock& clock_ = rig_.clock;
  RunContext& run_ = rig_.run;
  Context ctx_;
};

TEST_F(PluginTest, CaptureAveragesFramesOntoTheBlackboard) {
  DepthFrame a = rendered_frame(1), b = rendered_frame(2), dropped = a;
  std::fill(dropped.depth_mm.begin(), dropped.depth_mm.end(), 0);
  b.t_s = 0.5;
  camera_->frames = {a, dropped, b};
  auto capture =
      registry().create_behaviour("capture", params_of("capture", {{"average_frames", 2LL}}), run_);
  const Outcome o = run_behaviour(*capture);
  ASSERT_EQ(o.name, "succeeded") << o.message;
  const CapturedFrame* c = blackboard_.find(keys::kCapture);
  ASSERT_NE(c, nullptr);
  EXPECT_DOUBLE_EQ(c->frame.t_s, 0.5);
  EXPECT_EQ(c->frame.depth_mm, average_depth_frames({a, b}).depth_mm);
  EXPECT_EQ(c->joints.tilt_rad, pan_tilt_->q.tilt_rad);
}

// The pose of a depth frame is where the camera was when the frame was taken: align used to read
// the joints at align time, so a head that moved in between put the guess (and the crop) off.
TEST_F(PluginTest, AlignUsesTheJointsStampedAtCaptureNotTheJointsNow) {
  blackboard_.set(keys::kCapture, captured(rendered_frame(3)));
  pan_tilt_->q = {deg_to_rad(20.0), deg_to_rad(-10.0)};  // the head moved after the capture
  auto align = registry().create_behaviour("align", params_of("align"), run_);
  const Outcome o = run_behaviour(*align);
  ASSERT_EQ(o.name, "succeeded") << o.message;
  pan_tilt_->q = {0.0, deg_to_rad(8.0)};
  ASSERT_TRUE(aligned().T_camera_model);
  EXPECT_LT(translation_distance_m(*aligned().T_camera_model, T_camera_model_true()) * 1000.0, 2.0);
}

TEST_F(PluginTest, CaptureWithoutFramesEndsNoFrameAndADisconnectFails) {
  auto capture =
      registry().create_behaviour("capture", params_of("capture", {{"max_wait_s", 0.5}}), run_);
  const Outcome none = run_behaviour(*capture);
  EXPECT_EQ(none.name, "no_frame");
  EXPECT_GE(clock_.now_s(), 0.5);
  camera_->disconnected = true;
  const Outcome gone = run_behaviour(*capture);
  EXPECT_EQ(gone.name, "failed");
  EXPECT_NE(gone.message.find("USB device gone"), std::string::npos) << gone.message;
  EXPECT_NE(registry().validate_params("capture", params_of("capture", {{"average_frames", 0LL}})),
            "");
}

TEST_F(PluginTest, AlignFindsTheTruePoseAndDrawsIt) {
  blackboard_.set(keys::kCapture, captured(rendered_frame(3)));
  auto align = registry().create_behaviour("align", params_of("align"), run_);
  const Outcome o = run_behaviour(*align);
  ASSERT_EQ(o.name, "succeeded") << o.message;
  ASSERT_TRUE(aligned().T_camera_model);
  const Eigen::Isometry3d T = *aligned().T_camera_model;
  const Eigen::Isometry3d guess = aligned().T_camera_model_guess;
  const Eigen::Isometry3d truth = T_camera_model_true();
  // The guess is the nominal pose; the result is the true one.
  EXPECT_GT(translation_distance_m(guess, truth), 0.02);
  EXPECT_LT(translation_distance_m(T, truth) * 1000.0, 2.0);
  EXPECT_LT(rad_to_deg(rotation_angle_rad(T, truth)), 0.2);
  ASSERT_TRUE(aligned().quality);
  const AlignQuality q = *aligned().quality;
  ASSERT_TRUE(aligned().model);
  EXPECT_GT(aligned().model->points.size(), 1000u);
  EXPECT_EQ(q.method, "projective_icp");
  EXPECT_GT(q.inlier_fraction, 0.8);
  EXPECT_GT(q.iterations, 0);
  EXPECT_GT(q.time_ms, 0.0);
  EXPECT_GT(fs::file_size(ctx_.target_dir / "alignment.png"), 1000u);
}

// PCL's methods are the comparison and the fallback: they run on the same crop and their result
// goes through the same quality gate (closest-point ICP with the floor in the crop often
// stops short of the truth, which the gate then reports as a poor fit).
TEST_F(PluginTest, AlignWithPclIcpAndGicp) {
  blackboard_.set(keys::kCapture, captured(rendered_frame(4)));
  for (const char* method : {"pcl_icp", "pcl_gicp"}) {
    blackboard_.erase(keys::kAlign);
    auto align = registry().create_behaviour(
        "align", params_of("align", {{"method", std::string(method)}}), run_);
    const Outcome o = run_behaviour(*align);
    EXPECT_TRUE(o.name == "succeeded" || o.name == "poor_fit") << method << ": " << o.message;
    ASSERT_TRUE(aligned().quality) << method;
    const AlignQuality q = *aligned().quality;
    EXPECT_EQ(q.method, method);
    EXPECT_GT(q.iterations, 0) << method;
    EXPECT_EQ(o.name == "succeeded", aligned().T_camera_model.has_value()) << method;
    if (o.name == "succeeded") {
      EXPECT_LT(translation_distance_m(*aligned().T_camera_model, T_camera_model_true()) * 1000.0,
                10.0)
          << method;
    }
  }
  EXPECT_NE(
      registry().validate_params("align", params_of("align", {{"method", std::string("ndt")}})),
      "");
}

TEST_F(PluginTest, AlignWithAnEmptyCropIsNoTarget) {
  DepthFrame empty = rendered_frame(5);
  std::fill(empty.depth_mm.begin(), empty.depth_mm.end(), 0);
  blackboard_.set(keys::kCapture, captured(empty));
  auto align = registry().create_behaviour("align", params_of("align"), run_);
  const Outcome o = run_behaviour(*align);
  EXPECT_EQ(o.name, "no_target") << o.message;
  EXPECT_FALSE(aligned().T_camera_model);
  EXPECT_FALSE(aligned().quality);
}

TEST_F(PluginTest, AlignOfAWrongModelIsPoorFit) {
  // A box of the bunny's size stands in for the model: it cannot match the bunny's surface.
  const fs::path box = ctx_.target_dir / "box.off";
  {
    std::ofstream off(box);
    off << "OFF\n8 12 0\n";
    for (int i = 0; i < 8; ++i) {
      off << (i & 1 ? 0.12 : -0.12) << ' ' << (i & 2 ? 0.1 : -0.1) << ' ' << (i & 4 ? 0.12 : -0.12)
          << '\n';
    }
    off << "3 0 2 1\n3 1 2 3\n3 4 5 6\n3 5 7 6\n3 0 1 4\n3 1 5 4\n"
           "3 2 6 3\n3 3 6 7\n3 0 4 2\n3 2 4 6\n3 1 3 5\n3 3 7 5\n";
  }
  mission_.targets[0].model = box;
  blackboard_.set(keys::kCapture, captured(rendered_frame(6)));
  auto align = registry().create_behaviour("align", params_of("align"), run_);
  const Outcome o = run_behaviour(*align);
  EXPECT_EQ(o.name, "poor_fit") << o.message;
  EXPECT_FALSE(aligned().T_camera_model);
  EXPECT_TRUE(aligned().quality);
}

TEST_F(PluginTest, AlignWithoutAFrameFails) {
  auto align = registry().create_behaviour("align", params_of("align"), run_);
  EXPECT_EQ(run_behaviour(*align).name, "failed");
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
  const OrganizedCloud cloud = organized_cloud(frames[0]);
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
  const OrganizedCloud cloud = organized_cloud(*frame, Eigen::Vector3d::Zero(), 0.3, 5.0);
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : cloud.points) {
    if (OrganizedCloud::valid(p)) points.push_back(p.cast<double>());
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
      if (!OrganizedCloud::valid(p) || !OrganizedCloud::valid(l) || !OrganizedCloud::valid(r) ||
          !OrganizedCloud::valid(u) || !OrganizedCloud::valid(d)) {
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
  const IcpModel icp_model(cut);
  std::mt19937 guesses(11);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d guess = test::perturb(truth, 0.05, deg_to_rad(5.0), guesses);
    const RegistrationResult r =
        align_projective_icp(icp_model, *frame, Eigen::Vector3d::Zero(), guess, 0.1);
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
  } catch (const PluginError& e) {
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
  } catch (const PluginError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("openni2_colour: cannot open"), std::string::npos) << what;
    EXPECT_NE(what.find("/nonexistent/tour.oni"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace projtour
