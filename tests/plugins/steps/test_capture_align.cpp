// The capture and align steps, loaded as plugins the way the executor loads them, over drivers
// made for the test and frames from the simulator's renderer. The depth drivers that feed them
// in a real run are tested in tests/plugins/drivers/test_depth_drivers.cpp.
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
#include "projtour_test/loaded_plugins.hpp"
#include "projtour_test/rendered_scenes.hpp"
#include "projtour_test/run_rig.hpp"

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
host::PluginRegistry& registry() {
  return test::loaded_plugins({"capture", "align"});
}

Params params_of(const std::string& kind, const std::map<std::string, ParamValue>& values = {}) {
  return test::params_with(registry(), kind, values);
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
        head::HeadKinematics(mission_.robot).T_base_camera(pan_tilt_->q);
    return T_map_camera.inverse() * T_map_model_true;
  }

  // A rendered frame of the true target, with the depth-colour offset undone (the renderer
  // works in the depth optical frame).
  DepthFrame rendered_frame(unsigned seed) const {
    Eigen::Isometry3d T_depth_model = T_camera_model_true();
    T_depth_model.translation() -= mission_.robot.camera.depth_to_color_m;
    const perception::TriangleMesh mesh = perception::load_mesh(kBunny);
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
  EXPECT_EQ(c->frame.depth_mm, perception::average_depth_frames({a, b}).depth_mm);
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

}  // namespace
}  // namespace projtour
