// navigate and relocalize in an in-process dry run: the demo map's corridors, and small maps
// made to produce each failure outcome.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/navigation/localizer.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour_test/nav_rig.hpp"
#include "projtour_test/temp_dir.hpp"
#include "projtour_test/test_maps.hpp"

namespace projtour::nav_test {
namespace {

const std::string kDemoMap = PROJTOUR_SOURCE_DIR "/maps/malaga_campus.yaml";

std::filesystem::path temp_dir() {
  return test::scratch_dir();
}

struct CorridorGoal {
  const char* name;
  Pose2D goal;
};

class NavigateCorridors : public ::testing::TestWithParam<CorridorGoal> {};

TEST_P(NavigateCorridors, ReachesStandoffPoseOnTheDemoMap) {
  const Pose2D start{10.0, 1.0, 0.0};
  Rig rig(kDemoMap, start, 7);
  rig.idle(1.0);
  const TargetSpec target = target_for_goal("t", GetParam().goal);
  const Pose2D goal = navigation::standoff_pose(target);
  ASSERT_NEAR(goal.x_m, GetParam().goal.x_m, 1e-9);

  const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 400.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
  const Pose2D truth = rig.truth();
  const Pose2D estimate = rig.estimate().mean;
  // Succeeded is judged on the estimate; the truth must be as close, give or take the
  // localization error.
  EXPECT_LT(distance_m(estimate, goal), 0.10);
  EXPECT_LT(heading_error_rad(estimate, goal), deg_to_rad(5.0));
  EXPECT_LT(distance_m(truth, goal), 0.15);
  EXPECT_LT(heading_error_rad(truth, goal), deg_to_rad(6.0));
  const NavigateResult* navigated = rig.blackboard().find(keys::kNavigate);
  ASSERT_NE(navigated, nullptr);
  EXPECT_GT(navigated->planned_path.size(), 5u);
  ASSERT_TRUE(navigated->arrived_at);
  EXPECT_LT(distance_m(navigated->arrived_at->mean, goal), 0.10);
  std::printf("[ figures ] %s: arrival error truth-estimate %.3f m %.2f deg at t=%.1f s\n",
              GetParam().name, distance_m(truth, estimate),
              rad_to_deg(heading_error_rad(truth, estimate)), rig.now_s());
}

INSTANTIATE_TEST_SUITE_P(DemoMap, NavigateCorridors,
                         ::testing::Values(CorridorGoal{"north_corridor", {30.0, 1.0, 0.0}},
                                           CorridorGoal{"second_corridor", {22.0, -15.0, -kPi / 2}},
                                           CorridorGoal{"third_corridor", {42.0, -12.0, -kPi / 2}}),
                         [](const ::testing::TestParamInfo<CorridorGoal>& info) {
                           return info.param.name;
                         });

// The accuracy figure: localization error on arrival at stand-off poses, median over
// targets and 5 seeds, must be within 5 cm and 2 degrees. With the project's simulator, as a dry
// run drives the robot (biased odometry, its laser model).
TEST(NavigateAccuracy, MedianArrivalLocalizationErrorOverTargetsAndSeeds) {
  struct Leg {
    Pose2D start, goal;
  };
  const std::vector<Leg> legs = {
      {{14.0, 1.0, 0.0}, {24.0, 1.5, kPi / 2}},           // north corridor, facing its wall
      {{22.0, -2.0, -kPi / 2}, {22.5, -12.0, 0.0}},       // second corridor
      {{42.0, -30.0, kPi / 2}, {41.5, -20.0, kPi}},       // third corridor
      {{-4.0, -30.0, -kPi / 2}, {-4.0, -40.0, -kPi / 2}}  // first corridor
  };
  std::vector<double> trans_m, rot_deg;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    for (const Leg& leg : legs) {
      Rig rig(kDemoMap, leg.start, seed, Drivers::sim_plugin);
      rig.idle(1.0);
      const TargetSpec target = target_for_goal("t", leg.goal);
      const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 120.0);
      ASSERT_TRUE(outcome.has_value());
      ASSERT_EQ(outcome->name, "succeeded") << outcome->message;
      trans_m.push_back(distance_m(rig.estimate().mean, rig.truth()));
      rot_deg.push_back(rad_to_deg(heading_error_rad(rig.estimate().mean, rig.truth())));
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  const double worst_m = *std::max_element(trans_m.begin(), trans_m.end());
  const double worst_deg = *std::max_element(rot_deg.begin(), rot_deg.end());
  std::printf(
      "[ figures ] arrival localization error over %zu arrivals: median %.4f m %.3f deg, "
      "worst %.4f m %.3f deg\n",
      trans_m.size(), median(trans_m), median(rot_deg), worst_m, worst_deg);
  EXPECT_LE(median(trans_m), 0.05);
  EXPECT_LE(median(rot_deg), 2.0);
}

// The same with the project's simulator plugin (odometry with a systematic bias, its own
// laser model), as a dry run of the tour runs it.
TEST(NavigateSimPlugin, ReachesGoalsInTwoCorridorsWithTheSimDrivers) {
  for (const Pose2D& goal : {Pose2D{30.0, 1.0, 0.0}, Pose2D{22.0, -15.0, -kPi / 2}}) {
    Rig rig(kDemoMap, {10.0, 1.0, 0.0}, 11, Drivers::sim_plugin);
    rig.idle(1.0);
    const TargetSpec target = target_for_goal("t", goal);
    const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 300.0);
    ASSERT_TRUE(outcome.has_value());
    EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
    const Pose2D truth = rig.truth();
    EXPECT_LT(distance_m(truth, goal), 0.15);
    EXPECT_LT(heading_error_rad(truth, goal), deg_to_rad(6.0));
    std::printf(
        "[ figures ] sim plugin, goal (%.1f, %.1f): arrival localization error %.4f m "
        "%.3f deg at t=%.1f s\n",
        goal.x_m, goal.y_m, distance_m(truth, rig.estimate().mean),
        rad_to_deg(heading_error_rad(truth, rig.estimate().mean)), rig.now_s());
  }
}

TEST(NavigateOutcomes, UnreachableWhenTheGoalIsInAClosedRoom) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 1);
  rig.idle(0.5);
  const TargetSpec target = target_for_goal("room", {12.0, 8.0, 0.0});
  const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 10.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "unreachable");
  EXPECT_LT(rig.now_s(), 2.0);
}

TEST(NavigateOutcomes, BlockedWhenAnObstacleClosesTheCorridor) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 2);
  rig.world().add_box(12.0, 1.0, 12.4, 3.0);  // wall to wall, not on the robot's map
  rig.idle(0.5);
  Params params = rig.defaults("navigate");
  params.set("blocked_s", 5.0);
  const TargetSpec target = target_for_goal("far", {25.0, 2.0, 0.0});
  const auto outcome = rig.run("navigate", params, &target, 120.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "blocked") << outcome->message;
  // It stopped in front of the box, not in it.
  EXPECT_LT(rig.truth().x_m, 12.0);
  EXPECT_GT(rig.truth().x_m, 9.0);
}

TEST(NavigateOutcomes, ReplansAroundAnObstacleTheMapDoesNotHave) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 6);
  // Most of the corridor's width; 1.15 m left beside it, room for the robot's radius and the
  // 0.15 m navigate keeps from anything unmapped on each side (1 m left no margin at all, and
  // whether it squeezed through came down to the seed).
  rig.world().add_box(14.0, 1.0, 14.4, 1.85);
  rig.idle(0.5);
  const TargetSpec target = target_for_goal("far", {20.0, 2.0, 0.0});
  const auto first_plan_clear =
      navigation::PathPlanner(rig.map(), 0.35).plan({3.0, 2.0}, {20.0, 2.0});
  ASSERT_TRUE(first_plan_clear.has_value());
  const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 120.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
  // The last plan (made after the laser saw the box) passes beside it.
  ASSERT_NE(rig.blackboard().find(keys::kNavigate), nullptr);
  for (const Pose2D& p : rig.blackboard().find(keys::kNavigate)->planned_path) {
    if (p.x_m > 13.6 && p.x_m < 14.8) {
      EXPECT_GT(p.y_m, 1.85 + 0.35) << p.x_m << ", " << p.y_m;
    }
  }
  EXPECT_LT(distance_m(rig.truth(), navigation::standoff_pose(target)), 0.15);
}

// The loop map with its lower corridor closed by a box the robot's map lacks, and a goal beyond
// it: the way round by the upper corridor is some 30 m longer than the path left.
class ClosedLowerCorridor : public ::testing::Test {
 protected:
  ClosedLowerCorridor() : rig_(write_loop_map(temp_dir()).string(), {5.0, 2.0, 0.0}, 3) {
    rig_.world().add_box(9.0, 1.0, 9.4, 3.0);
    rig_.idle(0.5);
    params_ = rig_.defaults("navigate");
    params_.set("blocked_s", 5.0);
    params_.set("timeout_s", 400.0);
  }
  std::optional<Outcome> drive() { return rig_.run("navigate", params_, &target_, 400.0); }
  const std::vector<Pose2D>& last_plan() {
    const NavigateResult* result = rig_.blackboard().find(keys::kNavigate);
    if (result == nullptr) throw std::runtime_error("no navigate result");
    return result->planned_path;
  }

  Rig rig_;
  Params params_;
  const TargetSpec target_ = target_for_goal("beyond", {13.0, 2.0, 0.0});
};

// Regression (issue 14, seed 3's rabbit in the busy world): a new plan round something the laser
// sees is longer than the one it replaces, and driving it was read as no progress, so the
// robot was reported blocked half-way round. With the detour allowed, the robot drives it and
// arrives.
TEST_F(ClosedLowerCorridor, ADetourLongerThanThePathLeftIsProgressNotBlocked) {
  params_.set("max_detour_m", 50.0);
  const auto outcome = drive();
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
  EXPECT_LT(distance_m(rig_.truth(), navigation::standoff_pose(target_)), 0.15);
  const auto& path = last_plan();
  EXPECT_TRUE(std::any_of(path.begin(), path.end(), [](const Pose2D& p) { return p.y_m > 6.0; }))
      << "the last plan goes round by the upper corridor";
}

// Regression (issue 14, seed 5 in the busy world: 576 s to the first target): a way round longer
// than max_detour_m past the path left is not taken; the robot waits on its path for what blocks
// it to move, and is blocked if it never does.
TEST_F(ClosedLowerCorridor, AWayRoundLongerThanMaxDetourIsNotTakenTheRobotWaits) {
  ASSERT_EQ(params_.number("max_detour_m"), 10.0);
  const auto outcome = drive();
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "blocked") << outcome->message;
  EXPECT_LT(rig_.truth().x_m, 9.0);
  EXPECT_LT(rig_.truth().y_m, 3.0);
  for (const Pose2D& p : last_plan()) {
    EXPECT_LT(p.y_m, 3.0) << "the plan it kept goes round the block at " << p.x_m;
  }
}

// Regression (issue 14, seed 2's pillar in the busy world): something already within the
// clearance of the robot (a person who stepped up beside it) lay within the clearance of every
// path, since every path starts where the robot stands, and the robot waited beside it until
// blocked. A path that does not lead nearer to it is free.
TEST(NavigateOutcomes, SomethingBesideTheRobotDoesNotHoldItWhenThePathLeadsAway) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 4);
  // 0.40 m from the robot's centre, abeam: inside the 0.45 m navigate keeps from unmapped things.
  rig.world().add_box(2.95, 2.4, 3.05, 2.5);
  rig.idle(0.5);
  Params params = rig.defaults("navigate");
  params.set("blocked_s", 5.0);
  const TargetSpec target = target_for_goal("ahead", {8.0, 2.0, 0.0});
  const auto outcome = rig.run("navigate", params, &target, 60.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
  EXPECT_LT(distance_m(rig.truth(), navigation::standoff_pose(target)), 0.15);
}

TEST(NavigateOutcomes, TimeoutWhenTheGoalIsTooFarForTheTime) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 3);
  rig.idle(0.5);
  Params params = rig.defaults("navigate");
  params.set("timeout_s", 4.0);
  const TargetSpec target = target_for_goal("far", {25.0, 2.0, 0.0});
  const auto outcome = rig.run("navigate", params, &target, 30.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "timeout");
  EXPECT_NEAR(rig.now_s(), 0.5 + 4.0, 0.2);
}

TEST(NavigateOutcomes, LostWhenTheParticleCloudIsSpreadOut) {
  const auto map = write_corridor_map(temp_dir());
  Rig rig(map.string(), {3.0, 2.0, 0.0}, 4);
  rig.idle(0.5);
  rig.blackboard().set(keys::kLocalizationWiden, 3.0);
  rig.step();  // the service widens the cloud
  ASSERT_GT(navigation::position_std_m(rig.estimate()), 0.5);
  const TargetSpec target = target_for_goal("far", {25.0, 2.0, 0.0});
  const auto outcome = rig.run("navigate", rig.defaults("navigate"), &target, 10.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "lost");
}

TEST(NavigateOutcomes, LostWhenTheRobotIsTurnedUnnoticedAndScansStopFitting) {
  Rig rig(kDemoMap, {22.0, -5.0, -kPi / 2}, 8);
  rig.idle(1.0);
  // Kidnapped: turned a quarter turn with no odometry of it. (Displacements of half a metre
  // the filter often tracks back on its own while driving; this it cannot.)
  rig.world().truth.yaw_rad += kPi / 2;
  Params params = rig.defaults("navigate");
  params.set("lost_unconverged_s", 3.0);
  const TargetSpec target = target_for_goal("t", {22.0, -20.0, -kPi / 2});
  const auto outcome = rig.run("navigate", params, &target, 60.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "lost") << outcome->message;
}

TEST(Relocalize, RecoversAfterTheRobotIsDisplacedByHalfAMetre) {
  const Pose2D start{22.0, -5.0, -kPi / 2};
  Rig rig(kDemoMap, start, 5);
  rig.idle(2.0);
  ASSERT_LT(distance_m(rig.estimate().mean, rig.truth()), 0.1);
  // Kidnap: the base is carried 0.5 m sideways without its wheels turning.
  rig.world().truth.x_m += 0.5;
  rig.idle(3.0);
  ASSERT_GT(distance_m(rig.estimate().mean, rig.truth()), 0.3);
  // The cloud is still tight, but the scans no longer fit the map.
  ASSERT_NE(rig.blackboard().find(keys::kLocalizationConverged), nullptr);
  EXPECT_FALSE(*rig.blackboard().find(keys::kLocalizationConverged));
  const auto outcome = rig.run("relocalize", rig.defaults("relocalize"), nullptr, 60.0);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded") << outcome->message;
  EXPECT_LT(distance_m(rig.estimate().mean, rig.truth()), 0.10);
  EXPECT_LT(heading_error_rad(rig.estimate().mean, rig.truth()), deg_to_rad(3.0));
}

// The guard is off in tours (relocalize recovers, above); switched on, it walks the cloud back
// by itself.
TEST(DepletionGuard, WalksTheCloudBackAfterTheRobotIsCarriedTwoMetres) {
  const Pose2D start{22.0, -5.0, -kPi / 2};
  Rig rig(kDemoMap, start, 5, Drivers::harness, [](Params& p) { p.set("inject_max_frac", 0.1); });
  rig.idle(2.0);
  ASSERT_LT(distance_m(rig.estimate().mean, rig.truth()), 0.1);
  rig.world().truth.x_m -= 2.0;
  rig.idle(1.0);
  ASSERT_GT(distance_m(rig.estimate().mean, rig.truth()), 1.0);
  rig.idle(4.0);
  EXPECT_LT(distance_m(rig.estimate().mean, rig.truth()), 0.2);
  EXPECT_LT(heading_error_rad(rig.estimate().mean, rig.truth()), deg_to_rad(3.0));
}

}  // namespace
}  // namespace projtour::nav_test
