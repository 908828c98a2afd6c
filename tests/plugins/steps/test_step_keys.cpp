// navigate and relocalize against the keys their descriptors declare: each runs in the
// navigation tests' in-process dry run (projtour_test/nav_rig.hpp) over a blackboard on which
// every key it does not declare holds a value of a type no step uses
// (projtour_test/step_keys.hpp), so reading or writing one throws, naming it. aim, project, next
// and wait are checked the same way in test_aim_project_next.cpp.
#include <gtest/gtest.h>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour_test/nav_rig.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/step_keys.hpp"

namespace projtour::nav_test {
namespace {

const std::string kDemoMap = PROJTOUR_SOURCE_DIR "/maps/malaga_campus.yaml";
const Pose2D kStart{10.0, 1.0, 0.0};
// The localization service runs beside the step and uses its own keys (its tests check them).
const std::vector<std::string> kBeside = {"mrpt_localization"};

std::optional<Outcome> run_poisoned(Rig& rig, const test::StepKeys& step_keys,
                                    const std::string& kind, const TargetSpec* target,
                                    double max_s) {
  step_keys.poison(rig.blackboard());
  std::optional<Outcome> out;
  EXPECT_NO_THROW(out = rig.run(kind, rig.defaults(kind), target, max_s)) << kind;
  if (out) {
    EXPECT_TRUE(rig.registry().require(kind).declares_outcome(out->name)) << out->name;
  }
  return out;
}

TEST(StepKeys, NavigateToAStandOffUsesOnlyTheKeysItDeclares) {
  Rig rig(kDemoMap, kStart, 3);
  rig.idle(1.0);
  const test::StepKeys step_keys(PROJTOUR_PLUGIN_BUILD_DIR, "navigate", kBeside);
  const TargetSpec target = target_for_goal("t", {13.0, 1.0, 0.0});
  const std::uint64_t writes_before = rig.blackboard().writes();
  const auto out = run_poisoned(rig, step_keys, "navigate", &target, 120.0);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->name, "succeeded") << out->message;
  EXPECT_EQ(step_keys.written_since(rig.blackboard(), writes_before), step_keys.declared_writes());
}

// navigate read the believed calibration when it re-approached an aligned target (aim's
// reapproach) without declaring it, so `projtour graph` and the machine's data check missed the
// edge from calibrate. With align's result and the capture it fitted on the blackboard, start()
// takes that path: an undeclared read of the calibration throws here.
TEST(StepKeys, Regression_NavigateReadsTheCalibrationItDeclares) {
  Rig rig(kDemoMap, kStart, 3);
  rig.idle(1.0);
  const test::StepKeys step_keys(PROJTOUR_PLUGIN_BUILD_DIR, "navigate", kBeside);
  const TargetSpec target = target_for_goal("t", {13.0, 1.0, 0.0});
  // The capture at the estimate now, and align's pose of the target as the map has it.
  CapturedFrame capture;
  capture.base_estimate = rig.estimate();
  AlignResult aligned;
  aligned.joints = capture.joints;
  const head::HeadKinematics head(rig.mission().robot);
  aligned.T_camera_model =
      (isometry_from_pose2d(capture.base_estimate.mean) * head.T_base_camera(capture.joints))
          .inverse() *
      target.T_map_model;
  rig.blackboard().set(keys::kCapture, std::move(capture));
  rig.blackboard().set(keys::kAlign, std::move(aligned));
  ProjectorCalibration calibration;
  rig.blackboard().set(keys::kCalibration, std::move(calibration));
  run_poisoned(rig, step_keys, "navigate", &target, 5.0);

  // The control: this set-up does take the reapproach path, which reads the calibration. With a
  // Poison under that key too (as if it were undeclared), the same run throws naming it.
  rig.blackboard().erase(keys::kCalibration);
  rig.blackboard().set(
      Key<test::Poison>{keys::kCalibration.name, KeyScope::tour, "an undeclared key"},
      test::Poison{});
  try {
    rig.run("navigate", rig.defaults("navigate"), &target, 5.0);
    ADD_FAILURE() << "navigate did not read the calibration: the reapproach path was not taken";
  } catch (const BlackboardTypeError& e) {
    EXPECT_NE(std::string(e.what()).find("calibration"), std::string::npos) << e.what();
  }
}

// The declaration is what `projtour graph` draws: the demo mission's graph gained this edge
// from calibrate (the calibration believed for the rest of the run) to navigate when navigate
// declared the read; no other line of the graph changed.
TEST(StepKeys, GraphDrawsTheCalibrationNavigateReads) {
  const test::RunResult graph =
      test::run_projtour({"graph", PROJTOUR_SOURCE_DIR "/missions/demo_tour.yaml"});
  ASSERT_EQ(graph.status, 0) << graph.err;
  EXPECT_NE(graph.out.find("\"tour/visit/calibrate\" -> \"tour/visit/navigate\" "
                           "[label=\"calibration\", style=dotted"),
            std::string::npos)
      << graph.out;
}

TEST(StepKeys, RelocalizeUsesOnlyTheKeysItDeclares) {
  Rig rig(kDemoMap, kStart, 3);
  rig.idle(1.0);
  const test::StepKeys step_keys(PROJTOUR_PLUGIN_BUILD_DIR, "relocalize", kBeside);
  const auto out = run_poisoned(rig, step_keys, "relocalize", nullptr, 60.0);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(out->name, "succeeded") << out->message;
  // Its one write, the widening, the service takes (erases) at its next update, so it cannot be
  // read back here: the poisoned keys are the check.
}

// The localization service, as it runs for the whole tour: every key it does not declare
// poisoned while it updates on scans and odometry.
TEST(StepKeys, LocalizationServiceUsesOnlyTheKeysItDeclares) {
  Rig rig(kDemoMap, kStart, 3);
  const test::StepKeys service_keys(PROJTOUR_PLUGIN_BUILD_DIR, "mrpt_localization");
  ASSERT_FALSE(service_keys.poisoned().empty());
  service_keys.poison(rig.blackboard());
  const std::uint64_t writes_before = rig.blackboard().writes();
  ASSERT_NO_THROW(rig.idle(2.0));
  EXPECT_TRUE(service_keys.declared_writes().count(keys::kLocalization.name));
  EXPECT_EQ(service_keys.written_since(rig.blackboard(), writes_before),
            service_keys.declared_writes());
}

}  // namespace
}  // namespace projtour::nav_test
