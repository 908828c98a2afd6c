// Whole-sequence tests of the hierarchical state machine, in-process with scripted behaviours.
#include <gtest/gtest.h>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "executor_harness.hpp"
#include "projtour/contract/blackboard_keys.hpp"

namespace projtour::testing {
namespace {

TEST(Transitions, HappyPathOverThreeTargets) {
  Harness h;
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour"},
                                   happy_visit("rabbit"),
                                   happy_visit("pillar"),
                                   happy_visit("sign"),
                                   kTourEnd}));
  ASSERT_EQ(h.executor->records().size(), 3u);
  for (const auto& r : h.executor->records()) {
    EXPECT_EQ(r.outcome, "projected");
    EXPECT_EQ(r.retries, 0);
  }
  EXPECT_EQ(exit_code(h.executor->outcome()), 0);
}

TEST(Transitions, AlignPoorFitRecapturesThenSucceeds) {
  Harness h({"rabbit"});
  h.script("align", "poor_fit,succeeded");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  const std::string t = "rabbit";
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "succeeded", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "succeeded", "visit/calibrate", t),
                                   leaf("visit/calibrate", "succeeded", "visit/verify", t),
                                   leaf("visit/verify", "verified", "visit/project", t),
                                   leaf("visit/project", "succeeded", "visit/next", t),
                                   leaf("visit/next", "succeeded", "finish", t),
                                   {"exit visit @rabbit"},
                                   kTourEnd}));
  EXPECT_EQ(h.executor->records().at(0).retries, 1);
  EXPECT_EQ(h.behaviour("visit/capture").runs(), 2);
}

TEST(Transitions, RetriesExhaustedSkipTargetThenNextTarget) {
  Harness h({"rabbit", "pillar"});
  // Five poor fits: re-capture twice (capture's retries), re-aim twice (aim's), then skip.
  h.script("align", "poor_fit,poor_fit,poor_fit,poor_fit,poor_fit,succeeded");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  const std::string t = "rabbit";
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "succeeded", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "poor_fit", "skip_target", t),
                                   {"exit visit @rabbit"},
                                   happy_visit("pillar"),
                                   kTourEnd}));
  const auto& rabbit = h.executor->records().at(0);
  EXPECT_EQ(rabbit.outcome, "skipped");
  EXPECT_EQ(rabbit.reason, "poor_fit");
  EXPECT_EQ(rabbit.retries, 4);
  EXPECT_EQ(h.executor->records().at(1).outcome, "projected");
  EXPECT_EQ(exit_code(h.executor->outcome()), 3);
}

TEST(Transitions, NavigateTimeoutSkipsTarget) {
  Harness h({"rabbit", "pillar"});
  h.script("navigate", "timeout,succeeded");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "timeout", "skip_target", "rabbit"),
                                   {"exit visit @rabbit"},
                                   happy_visit("pillar"),
                                   kTourEnd}));
  EXPECT_EQ(h.executor->records().at(0).reason, "timeout");
}

TEST(Transitions, StateTimeoutEndsALongBehaviour) {
  Harness h({"rabbit"});
  h.load(R"(initial: visit
states:
  visit:
    for_each: target
    initial: wait
    states:
      wait:
        behaviour: scripted
        params: {ticks: 1000}
        timeout_s: 1.5
        on: {succeeded: finish, timeout: skip_target, failed: abort}
    on: {done: finish}
)");
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_SEQUENCE(h.recorder,
                  seq({{"enter tour", "enter visit @rabbit"},
                       leaf("visit/wait", "timeout", "skip_target", "rabbit"),
                       {"exit visit @rabbit", "outcome visit done",
                        "transition visit done -> finish", "exit tour", "outcome tour done"}}));
  EXPECT_NEAR(h.recorder.events[3].t_s, 1.5, 1e-9);  // the outcome event
  EXPECT_EQ(h.behaviour("visit/wait").ticks_seen(), 30);
}

TEST(Transitions, AbortEndsTheTourAsFailed) {
  Harness h;
  h.load(R"(initial: visit
states:
  visit:
    for_each: target
    initial: work
    states:
      work:
        behaviour: scripted
        params: {throw_on: 2}
        on: {succeeded: finish, failed: abort}
    on: {done: finish}
)");
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::aborted);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/work", "succeeded", "finish", "rabbit"),
                                   {"exit visit @rabbit", "enter visit @pillar"},
                                   leaf("visit/work", "failed", "abort", "pillar"),
                                   {"exit visit @pillar", "exit tour"}}));
  ASSERT_EQ(h.executor->records().size(), 2u);
  EXPECT_EQ(h.executor->records()[1].outcome, "failed");
  EXPECT_NE(h.executor->abort_reason().find("scripted failure on run 2"), std::string::npos);
  EXPECT_EQ(exit_code(h.executor->outcome()), 1);
}

TEST(Transitions, CancelDuringLongBehaviour) {
  Harness h;
  h.script("navigate", "succeeded", 1000);
  h.load_default();
  h.build();
  for (int i = 0; i < 10; ++i) h.executor->step();
  h.executor->request_cancel();
  EXPECT_EQ(h.run(), TourOutcome::interrupted);
  ASSERT_SEQUENCE(h.recorder, {"enter tour", "enter visit @rabbit", "enter visit/navigate @rabbit",
                               "outcome visit/navigate cancelled @rabbit",
                               "exit visit/navigate @rabbit", "exit visit @rabbit", "exit tour"});
  EXPECT_EQ(h.behaviour("visit/navigate").stops(), 1);
  EXPECT_TRUE(h.executor->records().empty());
  EXPECT_EQ(h.executor->current_target(), std::optional<std::size_t>(0));
  EXPECT_TRUE(h.executor->ignored_cancel().empty());
  EXPECT_EQ(exit_code(h.executor->outcome()), 130);
}

TEST(Transitions, BehaviourIgnoringCancelIsStoppedAfterGrace) {
  Harness h;
  h.script("navigate", "succeeded", 1000, 0, /*ignore_cancel=*/true);
  h.load_default();
  ExecutorOptions options;
  options.cancel_grace_s = 2.0;
  h.build(options);
  for (int i = 0; i < 10; ++i) h.executor->step();
  const double cancelled_at_s = h.clock.now_s();
  h.executor->request_cancel();
  EXPECT_EQ(h.run(), TourOutcome::interrupted);
  ASSERT_SEQUENCE(h.recorder, {"enter tour", "enter visit @rabbit", "enter visit/navigate @rabbit",
                               "outcome visit/navigate cancelled @rabbit",
                               "exit visit/navigate @rabbit", "exit visit @rabbit", "exit tour"});
  ASSERT_EQ(h.executor->ignored_cancel(),
            std::vector<std::string>{"tour/visit/navigate (navigate)"});
  EXPECT_NEAR(h.clock.now_s() - cancelled_at_s, 2.0 + 0.05, 1e-9);
  EXPECT_NE(h.recorder.events[3].message.find("ignored the cancel"), std::string::npos);
  EXPECT_EQ(h.behaviour("visit/navigate").stops(), 1);
}

TEST(Transitions, PauseAndResume) {
  Harness h({"rabbit"});
  h.script("navigate", "succeeded", 10);
  h.load_default();
  h.build();
  for (int i = 0; i < 4; ++i) h.executor->step();
  h.executor->pause();
  EXPECT_TRUE(h.executor->paused());
  const int ticks_before = h.behaviour("visit/navigate").ticks_seen();
  for (int i = 0; i < 100; ++i) h.executor->step();
  EXPECT_EQ(h.behaviour("visit/navigate").ticks_seen(), ticks_before);
  EXPECT_EQ(h.behaviour("visit/navigate").pauses(), 1);
  h.executor->resume();
  EXPECT_EQ(h.behaviour("visit/navigate").resumes(), 1);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour"}, happy_visit("rabbit"), kTourEnd}));
  // Navigate's 10 ticks: the 100 paused ones stand mission time still (issue 16).
  EXPECT_NEAR(h.recorder.events[3].t_s, 0.05 * 10, 1e-9);
}

TEST(Transitions, PausedTimeDoesNotCountTowardTimeout) {
  Harness h({"rabbit"});
  h.load(R"(initial: visit
states:
  visit:
    for_each: target
    initial: wait
    states:
      wait:
        behaviour: scripted
        params: {ticks: 20}
        timeout_s: 1.5
        on: {succeeded: finish, timeout: skip_target, failed: abort}
    on: {done: finish}
)");
  h.build();
  for (int i = 0; i < 10; ++i) h.executor->step();
  h.executor->pause();
  for (int i = 0; i < 100; ++i) h.executor->step();
  h.executor->resume();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  EXPECT_EQ(h.executor->records().at(0).outcome, "projected");
}

TEST(Transitions, ThrowInTickIsFailedWithMessage) {
  Harness h({"rabbit", "pillar"});
  h.script("aim", "succeeded", 1, /*throw_on=*/1);
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "succeeded", "visit/aim", "rabbit"),
                                   leaf("visit/aim", "failed", "skip_target", "rabbit"),
                                   {"exit visit @rabbit"},
                                   happy_visit("pillar"),
                                   kTourEnd}));
  EXPECT_EQ(h.recorder.events[7].message, "scripted failure on run 1");
  EXPECT_EQ(h.executor->records()[0].reason, "failed: scripted failure on run 1");
}

TEST(Transitions, UndeclaredOutcomeBecomesFailed) {
  Harness h({"rabbit"});
  h.script("project", "applause");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  EXPECT_EQ(h.recorder.lines()[27], "outcome visit/project failed @rabbit");
  EXPECT_NE(h.executor->records()[0].reason.find("does not declare: \"applause\""),
            std::string::npos);
}

TEST(Transitions, NavigateLostRelocalizesThenNavigatesAgain) {
  Harness h({"rabbit"});
  h.script("navigate", "lost,succeeded");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  const std::string t = "rabbit";
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "lost", "visit/relocalize", t),
                                   leaf("visit/relocalize", "succeeded", "visit/navigate", t),
                                   leaf("visit/navigate", "succeeded", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "succeeded", "visit/align", t),
                                   leaf("visit/align", "succeeded", "visit/calibrate", t),
                                   leaf("visit/calibrate", "succeeded", "visit/verify", t),
                                   leaf("visit/verify", "verified", "visit/project", t),
                                   leaf("visit/project", "succeeded", "visit/next", t),
                                   leaf("visit/next", "succeeded", "finish", t),
                                   {"exit visit @rabbit"},
                                   kTourEnd}));
}

TEST(Transitions, RelocalizeFailingSkipsTarget) {
  Harness h({"rabbit"});
  h.script("navigate", "lost");
  h.script("relocalize", "lost");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "lost", "visit/relocalize", "rabbit"),
                                   leaf("visit/relocalize", "lost", "skip_target", "rabbit"),
                                   {"exit visit @rabbit"},
                                   kTourEnd}));
}

TEST(Transitions, CaptureNoFrameRetriesThenSkips) {
  Harness h({"rabbit"});
  h.script("capture", "no_frame");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  const std::string t = "rabbit";
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @rabbit"},
                                   leaf("visit/navigate", "succeeded", "visit/aim", t),
                                   leaf("visit/aim", "succeeded", "visit/capture", t),
                                   leaf("visit/capture", "no_frame", "visit/capture", t),
                                   leaf("visit/capture", "no_frame", "visit/capture", t),
                                   leaf("visit/capture", "no_frame", "skip_target", t),
                                   {"exit visit @rabbit"},
                                   kTourEnd}));
  EXPECT_EQ(h.executor->records()[0].retries, 2);
}

TEST(Transitions, ProjectOffScreenSkips) {
  Harness h({"rabbit"});
  h.script("project", "off_screen");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  const auto lines = h.recorder.lines();
  EXPECT_EQ(lines[lines.size() - 8], "transition visit/project off_screen -> skip_target @rabbit");
}

TEST(Transitions, CustomMachineWithNestedComposites) {
  Harness h({"rabbit", "pillar"});
  h.load(R"(name: show
initial: setup
states:
  setup:
    behaviour: scripted
    on: {succeeded: visit, failed: abort}
  visit:
    for_each: target
    initial: approach
    states:
      approach:
        initial: drive
        states:
          drive:
            behaviour: scripted
            params: {ticks: 3}
            on: {succeeded: turn, failed: skip_target}
          turn:
            behaviour: scripted
            on: {succeeded: finish, failed: skip_target}
        on: {done: present}
      present:
        behaviour: scripted
        params: {ticks: 2}
        on: {succeeded: finish, failed: skip_target}
    on: {done: wrap_up}
  wrap_up:
    behaviour: scripted
    on: {succeeded: finish, failed: abort}
)");
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  auto visit = [](const std::string& t) {
    return seq({{"enter visit @" + t, "enter visit/approach @" + t},
                leaf("visit/approach/drive", "succeeded", "visit/approach/turn", t),
                leaf("visit/approach/turn", "succeeded", "finish", t),
                {"exit visit/approach @" + t, "outcome visit/approach done @" + t,
                 "transition visit/approach done -> visit/present @" + t},
                leaf("visit/present", "succeeded", "finish", t),
                {"exit visit @" + t}});
  };
  ASSERT_SEQUENCE(h.recorder, seq({{"enter show"},
                                   leaf("setup", "succeeded", "visit", ""),
                                   visit("rabbit"),
                                   visit("pillar"),
                                   {"outcome visit done", "transition visit done -> wrap_up"},
                                   leaf("wrap_up", "succeeded", "finish", ""),
                                   {"exit show", "outcome show done"}}));
}

TEST(Transitions, StartFromAnyState) {
  Harness h;
  h.load_default();
  h.build();
  h.executor->start_at("tour/visit/align", 1);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  const std::string t = "pillar";
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour", "enter visit @pillar"},
                                   leaf("visit/align", "succeeded", "visit/calibrate", t),
                                   leaf("visit/calibrate", "succeeded", "visit/verify", t),
                                   leaf("visit/verify", "verified", "visit/project", t),
                                   leaf("visit/project", "succeeded", "visit/next", t),
                                   leaf("visit/next", "succeeded", "finish", t),
                                   {"exit visit @pillar"},
                                   happy_visit("rabbit"),
                                   happy_visit("sign"),
                                   kTourEnd}));
}

// The for_each runs the visiting order (next used to choose, and the executor to fall back on
// mission order after a skip): `order: nearest` ranks by path length on the run's map.
TEST(Transitions, ForEachOrderNearestGoesByPathLengthNotStraightLine) {
  // 12 x 12 m free map with a wall at x = 1.4 from y = -6 to y = 3: "front" is the closest in a
  // straight line but behind the wall.
  auto map = std::make_shared<mrpt::maps::COccupancyGridMap2D>(-2.0f, 10.0f, -6.0f, 6.0f, 0.05f);
  const auto first_visited = [&](const std::string& order, bool wall) {
    map->fill(1.0f);
    if (wall) {
      for (float y = -6.0f; y <= 3.0f; y += 0.025f) {
        for (float x = 1.3f; x <= 1.45f; x += 0.025f) map->setPos(x, y, 0.0f);
      }
    }
    Harness h({"front", "left", "far"});
    h.mission.targets[0].T_map_model = isometry_from_xyz_rpy(2.5, -3.0, 0.9, 0, 0, 0);
    h.mission.targets[1].T_map_model = isometry_from_xyz_rpy(-1.0, 4.5, 0.9, 0, 0, 0);
    h.mission.targets[2].T_map_model = isometry_from_xyz_rpy(6.0, 0.0, 0.9, 0, 0, 0);
    h.mission.robot.base.radius_m = 0.3;
    h.run_context.map = map;
    PoseEstimate2D here;
    here.mean = Pose2D{0.0, -3.0, 0.0};
    h.blackboard.set(keys::kLocalization, here);
    h.load(R"(initial: visit
states:
  visit:
    for_each: target
    order: )" +
           order + R"(
    initial: next
    states:
      next:
        behaviour: scripted
        on: {succeeded: finish, failed: abort}
    on: {done: finish}
)");
    h.build();
    EXPECT_EQ(h.run(), TourOutcome::completed);
    return h.executor->records().front().id;
  };
  // Straight line: front's stand-off (3.5, -3) is 3.5 m away, left's (0, 4.5) 7.5 m, far's
  // (7, 0) 7.6 m; by path front needs to go round the wall's end at y = 3.
  EXPECT_EQ(first_visited("nearest", true), "left");
  EXPECT_EQ(first_visited("mission", true), "front");
  EXPECT_EQ(first_visited("nearest", false), "front");
}

TEST(MachineValidation, OrderBelongsToAForEach) {
  Harness h;
  host::Diagnostics diag;
  EXPECT_FALSE(h.parse(R"(initial: a
states:
  a:
    initial: s
    order: nearest
    states:
      s: {behaviour: scripted, on: {succeeded: finish, failed: abort}}
    on: {done: finish}
)",
                       diag));
  EXPECT_NE(diag.format().find("machine.yaml:5:12: states.a.order: order: belongs to a for_each"),
            std::string::npos)
      << diag.format();
}

}  // namespace
}  // namespace projtour::testing
