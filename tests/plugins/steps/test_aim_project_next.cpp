#include <gtest/gtest.h>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/head/projection.hpp"
#include "projtour_test/geometry_rig.hpp"
#include "projtour_test/step_keys.hpp"

using namespace projtour;
using namespace projtour::geometry_test;

namespace {

const Pose2D kBase{0.3, -0.1, deg_to_rad(5)};

PoseEstimate2D estimate_at(const Pose2D& p) {
  PoseEstimate2D e;
  e.mean = p;
  e.covariance = Eigen::Matrix3d::Identity() * 1e-4;
  return e;
}

// Aims the head (instantly) and puts the exact aligned pose on the blackboard.
void aim_and_align(Rig& rig, const Eigen::Isometry3d& model_error = Eigen::Isometry3d::Identity()) {
  const TargetSpec& t = *rig.ctx.target;
  const head::HeadKinematics k(rig.mission.robot);
  const Eigen::Vector3d p_base =
      isometry_from_pose2d(kBase).inverse() * t.T_map_model.translation();
  const auto q = k.aim_projector_at(p_base);
  ASSERT_TRUE(q);
  rig.pan_tilt->measured_ = *q;
  AlignResult aligned;
  aligned.T_camera_model = rig.exact_T_camera_model(kBase, t) * model_error;
  aligned.T_camera_model_guess =
      rig.exact_T_camera_model(kBase, t) * isometry_from_xyz_rpy(0.0, 0.03, 0.0, 0, 0, 0.02);
  aligned.joints = *q;
  rig.blackboard.set(keys::kAlign, std::move(aligned));
}

const ProjectResult& projected(const Rig& rig) {
  const ProjectResult* r = rig.blackboard.find(keys::kProject);
  if (r == nullptr) throw std::runtime_error("project published no result");
  return *r;
}

bool any_contains(const std::vector<std::string>& lines, const std::string& what) {
  for (const auto& l : lines) {
    if (l.find(what) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

// ---- aim -------------------------------------------------------------------------------------

TEST(Aim, PutsTheModelPointsCentroidOnTheProjectorAxisWithProjectorBlank) {
  Rig rig;
  rig.blackboard.set(keys::kLocalization, estimate_at(kBase));
  rig.projector->show(cv::Mat::zeros(800, 1280, CV_8UC3));  // something on screen before
  auto aim = rig.make("aim", {{"settle_s", 0.5}});
  const double t0 = rig.clock.now_s();
  const Outcome out = rig.run(*aim);
  ASSERT_EQ(out.name, "succeeded") << out.message;
  ASSERT_EQ(rig.pan_tilt->commands.size(), 1u);
  EXPECT_TRUE(rig.pan_tilt->projector_blank_at_command[0]);
  EXPECT_GE(rig.clock.now_s() - t0, 0.5 + 3 * 0.1 - 1e-9);  // reached (3 ticks) + settle
  const TargetSpec& t = rig.mission.targets[0];
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : t.model_points) centroid += p / 4.0;
  const Eigen::Vector3d p_projector =
      (isometry_from_pose2d(kBase) *
       head::HeadKinematics(rig.mission.robot).T_base_projector(rig.pan_tilt->commands[0]))
          .inverse() *
      (t.T_map_model * centroid);
  EXPECT_GT(p_projector.z(), 2.0);
  EXPECT_LT(p_projector.head<2>().norm(), 1e-8);
}

TEST(Aim, WithoutLocalizationFailsClearly) {
  Rig rig;
  auto aim = rig.make("aim");
  const Outcome out = rig.run(*aim);
  EXPECT_EQ(out.name, "failed");
  EXPECT_NE(out.message.find("localization"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("front"), std::string::npos) << out.message;
  EXPECT_TRUE(rig.pan_tilt->commands.empty());
}

TEST(Aim, TargetOverheadIsOutOfReachWithTheReason) {
  Rig rig;
  rig.mission.targets[0].T_map_model = isometry_from_xyz_rpy(0.6, -0.1, 6.0, 0, 0, kPi);
  rig.blackboard.set(keys::kLocalization, estimate_at(kBase));
  auto aim = rig.make("aim");
  const Outcome out = rig.run(*aim);
  EXPECT_EQ(out.name, "out_of_reach");
  EXPECT_NE(out.message.find("tilt"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("front"), std::string::npos) << out.message;
}

TEST(Aim, RejectsUnknownAimPoint) {
  Rig rig;
  EXPECT_THROW(rig.make("aim", {{"aim_at", std::string("nose")}}), std::invalid_argument);
}

// ---- project ---------------------------------------------------------------------------------

TEST(Project, ShowsContentOnTheModelPointsForTheDwellThenBlanks) {
  Rig rig;
  aim_and_align(rig);
  auto project = rig.make("project");
  const double t0 = rig.clock.now_s();
  const Outcome out = rig.run(*project);
  ASSERT_EQ(out.name, "succeeded") << out.message;
  EXPECT_NEAR(rig.clock.now_s() - t0, 2.0, 0.1 + 1e-9);  // the target's dwell_s
  EXPECT_NEAR(projected(rig).shown_s.value_or(-1.0), 2.0, 0.1 + 1e-9);
  EXPECT_TRUE(rig.projector->is_blank());
  ASSERT_EQ(rig.projector->frames.size(), 1u);  // a still image is shown once
  EXPECT_TRUE(std::filesystem::exists(rig.ctx.target_dir / "projector.png"));

  ASSERT_TRUE(projected(rig).pixels_after_align);
  ASSERT_TRUE(projected(rig).pixels_before_align);
  const head::Quad2d after = *projected(rig).pixels_after_align;
  const head::Quad2d before = *projected(rig).pixels_before_align;
  EXPECT_GT((after[0] - before[0]).norm(), 5.0);  // the guess was off by 3 cm
  // The exact pixels of the Model Points, computed independently here.
  const head::HeadKinematics k(rig.mission.robot);
  const Eigen::Isometry3d T_projector_model = k.T_projector_camera(rig.pan_tilt->measured_) *
                                              *rig.blackboard.find(keys::kAlign)->T_camera_model;
  const cv::Mat& frame = rig.projector->frames[0];
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : after) centre += p / 4.0;
  const cv::Vec3b colours[4] = {{0, 0, 255}, {0, 255, 0}, {255, 0, 0}, {255, 255, 255}};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d expected = *rig.mission.robot.projector.intrinsics.project(
        T_projector_model * rig.ctx.target->model_points[i]);
    EXPECT_LT((after[i] - expected).norm(), 1e-9);
    const Eigen::Vector2d inside = after[i] + 0.1 * (centre - after[i]);
    EXPECT_EQ(frame.at<cv::Vec3b>(cvRound(inside.y()), cvRound(inside.x())), colours[i]) << i;
    const Eigen::Vector2d outside = after[i] - 0.1 * (centre - after[i]);
    EXPECT_EQ(frame.at<cv::Vec3b>(cvRound(outside.y()), cvRound(outside.x())), cv::Vec3b(0, 0, 0));
  }
}

TEST(Project, DwellParameterOverridesTheTarget) {
  Rig rig;
  aim_and_align(rig);
  auto project = rig.make("project", {{"dwell_s", 0.5}});
  const Outcome out = rig.run(*project);
  ASSERT_EQ(out.name, "succeeded") << out.message;
  EXPECT_NEAR(projected(rig).shown_s.value_or(-1.0), 0.5, 1e-9);
}

TEST(Project, ModelPointOutsideTheImageIsOffScreen) {
  Rig rig;
  aim_and_align(rig, isometry_from_xyz_rpy(0.0, 1.5, 0.0, 0, 0, 0));  // 1.5 m to the side
  auto project = rig.make("project");
  const Outcome out = rig.run(*project);
  EXPECT_EQ(out.name, "off_screen");
  EXPECT_NE(out.message.find("front"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("outside"), std::string::npos) << out.message;
  EXPECT_TRUE(rig.projector->frames.empty());
  EXPECT_TRUE(rig.projector->is_blank());
}

TEST(Project, UnreadableContentFailsNamingTargetAndFile) {
  Rig rig;
  const auto bogus = rig.dir / "not_an_image.png";
  std::ofstream(bogus) << "this is not a PNG";
  rig.mission.targets[0].content = bogus;
  aim_and_align(rig);
  auto project = rig.make("project");
  const Outcome out = rig.run(*project);
  EXPECT_EQ(out.name, "failed");
  EXPECT_NE(out.message.find("target front"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("not_an_image.png"), std::string::npos) << out.message;
}

TEST(Project, DegenerateQuadFails) {
  Rig rig;
  auto& mp = rig.mission.targets[0].model_points;
  std::swap(mp[2], mp[3]);  // bow tie
  aim_and_align(rig);
  auto project = rig.make("project");
  Outcome out = rig.run(*project);
  EXPECT_EQ(out.name, "failed");
  EXPECT_NE(out.message.find("self-crossing"), std::string::npos) << out.message;
  EXPECT_NE(out.message.find("target front"), std::string::npos) << out.message;
  std::swap(mp[2], mp[3]);
  for (int i = 0; i < 4; ++i) mp[i] = Eigen::Vector3d(0.0, 0.2 - 0.1 * i, 0.0);  // collinear
  out = rig.run(*project);
  EXPECT_EQ(out.name, "failed");
  EXPECT_NE(out.message.find("degenerate"), std::string::npos) << out.message;
}

TEST(Project, NonCoplanarModelPointsWarnWithResidualAndStillProject) {
  Rig rig;
  rig.mission.targets[0].model_points[2].x() += 0.04;  // 40 mm out of plane
  aim_and_align(rig);
  auto project = rig.make("project");
  const Outcome out = rig.run(*project);
  EXPECT_EQ(out.name, "succeeded") << out.message;
  const auto warnings = rig.log.messages(LogLevel::warning);
  ASSERT_TRUE(any_contains(warnings, "not coplanar")) << warnings.size();
  EXPECT_TRUE(any_contains(warnings, "10.0 mm"));  // 40 mm / 4 from the best plane
  EXPECT_TRUE(any_contains(warnings, "target front"));
}

TEST(Project, CancelBlanksAndRecordsTheTimeShown) {
  Rig rig;
  aim_and_align(rig);
  rig.ticks_before_cancel = 7;
  auto project = rig.make("project");
  const Outcome out = rig.run(*project);
  EXPECT_EQ(out.name, "cancelled");
  EXPECT_TRUE(rig.projector->is_blank());
  EXPECT_NEAR(projected(rig).shown_s.value_or(-1.0), 0.7, 0.1 + 1e-9);
}

TEST(Project, VideoContentPlaysThroughTheDwellByMissionTime) {
  Rig rig;
  const auto video = rig.dir / "clip.avi";
  {
    cv::VideoWriter writer(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                           cv::Size(320, 200));
    if (!writer.isOpened()) GTEST_SKIP() << "this OpenCV cannot write MJPG video";
    for (int i = 0; i < 10; ++i) {
      writer.write(cv::Mat(200, 320, CV_8UC3, cv::Scalar(20 * i, 255 - 20 * i, 128)));
    }
  }
  rig.mission.targets[0].content = video;
  aim_and_align(rig);
  auto project = rig.make("project");
  const Outcome out = rig.run(*project, 0.05);
  ASSERT_EQ(out.name, "succeeded") << out.message;
  // 2 s at 10 fps over a 1 s clip: 20 frames shown, looping once.
  EXPECT_GE(rig.projector->frames.size(), 19u);
  EXPECT_LE(rig.projector->frames.size(), 21u);
  EXPECT_TRUE(rig.projector->is_blank());
}

// ---- next ------------------------------------------------------------------------------------

// next only leaves the target safely; the for_each chooses the next target (executor tests).
TEST(Next, StowsTheHeadAndBlanksTheProjector) {
  Rig rig;
  rig.projector->show(cv::Mat::zeros(800, 1280, CV_8UC3));
  auto next = rig.make("next");
  const Outcome out = rig.run(*next);
  ASSERT_EQ(out.name, "succeeded") << out.message;
  EXPECT_TRUE(rig.projector->is_blank());
  ASSERT_EQ(rig.pan_tilt->commands.size(), 1u);
  EXPECT_NEAR(rig.pan_tilt->commands[0].tilt_rad, deg_to_rad(10), 1e-12);  // the stow angles
  EXPECT_TRUE(rig.pan_tilt->reached());
}

// ---- declared keys ---------------------------------------------------------------------------

// Each step runs over a blackboard on which every key it does not declare holds a value of a
// type no step uses (step_keys.hpp): reading or writing such a key throws, naming it. A step that
// succeeds has written each key it declares writing.
namespace {

void expect_only_declared_keys(Rig& rig, const std::string& kind) {
  const test::StepKeys step_keys(PROJTOUR_PLUGIN_BUILD_DIR, kind);
  ASSERT_FALSE(step_keys.poisoned().empty());
  step_keys.poison(rig.blackboard);
  const std::uint64_t writes_before = rig.blackboard.writes();
  auto step = rig.make(kind);
  Outcome out;
  ASSERT_NO_THROW(out = rig.run(*step)) << kind;
  ASSERT_EQ(out.name, "succeeded") << out.message;
  EXPECT_EQ(step_keys.written_since(rig.blackboard, writes_before), step_keys.declared_writes());
}

// The capture align fitted: at the head's angles now, the base at kBase.
void put_capture(Rig& rig) {
  CapturedFrame capture;
  capture.joints = rig.pan_tilt->measured_;
  capture.base_estimate = estimate_at(kBase);
  rig.blackboard.set(keys::kCapture, std::move(capture));
}

}  // namespace

TEST(StepKeys, AimAtTheAlignedPoseUsesOnlyTheKeysItDeclares) {
  Rig rig;
  rig.blackboard.set(keys::kLocalization, estimate_at(kBase));
  aim_and_align(rig);
  put_capture(rig);  // fitted this capture: aim reads the calibration too
  expect_only_declared_keys(rig, "aim");
}

TEST(StepKeys, ProjectUsesOnlyTheKeysItDeclares) {
  Rig rig;
  aim_and_align(rig);
  expect_only_declared_keys(rig, "project");
}

TEST(StepKeys, NextUsesNoKey) {
  Rig rig;
  expect_only_declared_keys(rig, "next");
}

// wait (plugins/steps/closed_loop) keeps the projector blank for its duration and uses no key.
TEST(StepKeys, WaitUsesNoKey) {
  Rig rig;
  rig.registry.load_library(std::filesystem::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                            "libprojtour_closed_loop.so");
  expect_only_declared_keys(rig, "wait");
}
