// Injected faults (issue 8, item 1): each test runs the real `projtour run --dry-run` on the
// two-target integration tour with one fault on the first target (the rabbit), and checks the
// chain of outcomes the fault causes, that the tour goes on to project the sign, the exit
// status, the reason in report.json, and (in the fixture) that the projector was blank whenever
// the base or the head moved.
#include <algorithm>
#include <regex>

#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

constexpr const char* kFaulted = "rabbit";
constexpr const char* kNext = "open-day-sign";

class Faults : public DryRunTest {
 protected:
  static constexpr const char* kNextChain =
      "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
      "calibrate:succeeded > verify:verified > project:succeeded > next:succeeded > finish";

  // The checks every fault shares: the run ends as `exit_code` says and the sign after the
  // faulted rabbit is still visited and projected, through `next_chain`.
  DryRunResult run_fault(const std::string& world, int exit_code,
                         const std::string& next_chain = kNextChain) {
    DryRunResult r = dry_run(world, "run");
    EXPECT_EQ(r.exit_code, exit_code) << r.err;
    EXPECT_EQ(r.report.at("outcome").get<std::string>(),
              exit_code == 0 ? "completed" : "completed_with_skips");
    const Json& next = report_target(r.report, kNext);
    EXPECT_EQ(next.at("outcome").get<std::string>(), "projected") << next.dump();
    const auto chain = outcome_chain(r.events, kNext);
    EXPECT_EQ(join(chain), next_chain) << "the target after the fault";
    EXPECT_GE(shows_on(r.dir, kNext), 1) << "the simulated projector never showed the sign";
    return r;
  }

  // The faulted target was skipped for a reason that matches `reason`.
  static void expect_skipped(const DryRunResult& r, const std::string& reason) {
    const Json& t = report_target(r.report, kFaulted);
    EXPECT_EQ(t.at("outcome").get<std::string>(), "skipped");
    ASSERT_TRUE(t.contains("reason")) << t.dump();
    EXPECT_TRUE(std::regex_search(t.at("reason").get<std::string>(), std::regex(reason)))
        << t.at("reason").get<std::string>() << " !~ " << reason;
    if (t.contains("projected_s")) {
      EXPECT_EQ(t.at("projected_s").get<double>(), 0.0) << "a skipped target was not projected";
    }
  }
};

// Half the frames arrive empty: capture drops them and waits for a good one within its
// max_wait_s, so the fault is absorbed without even a retry.
TEST_F(Faults, HalfTheFramesDroppedIsRecoveredByWaiting) {
  const DryRunResult r = run_fault("w_frame_dropout.yaml", 0);
  const Json& t = report_target(r.report, kFaulted);
  EXPECT_EQ(t.at("outcome").get<std::string>(), "projected");
  EXPECT_FALSE(t.contains("reason"));
  const auto chain = outcome_chain(r.events, kFaulted);
  EXPECT_EQ(std::count(chain.begin(), chain.end(), "capture:no_frame"), 0) << join(chain);
  EXPECT_EQ(chain.back(), "finish") << join(chain);
  EXPECT_EQ(std::count(chain.begin(), chain.end(), "project:succeeded"), 1) << join(chain);
  // A frame is due every 50 ms tick (30 Hz camera): a capture of more than one tick waited
  // through dropped frames, so the fault did act.
  const auto steps = step_outcomes(r.events, kFaulted);
  const auto capture = std::find_if(steps.begin(), steps.end(),
                                    [](const StepOutcome& s) { return s.step == "capture"; });
  ASSERT_NE(capture, steps.end());
  double entered_s = -1.0;
  for (const Json& e : r.events) {
    if (e.at("event").get<std::string>() == "enter" &&
        e.at("state").get<std::string>() == "tour/visit/capture" && e.at("target").is_string() &&
        e.at("target").get<std::string>() == kFaulted) {
      entered_s = e.at("t").get<double>();
      break;
    }
  }
  EXPECT_GT(capture->t_s - entered_s, 0.075) << "no frame was dropped: the test shows nothing";
}

// Every frame empty: capture times out, re-captures twice (its retries), then the target is
// skipped with capture's reason.
TEST_F(Faults, AllFramesDroppedRetriesCaptureThenSkips) {
  const DryRunResult r = run_fault("w_frames_lost.yaml", 3);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:no_frame > capture:no_frame > "
            "capture:no_frame > skip_target");
  expect_skipped(r, R"(^no_frame: got 0 of 1 frame\(s\) in 2 s \([1-9][0-9]* dropped\)$)");
  EXPECT_EQ(report_target(r.report, kFaulted).at("retries").get<long long>(), 2);
}

// Regression: a fault on a revisit acted on the first visit to that place, since the two
// targets are one object, equally near the robot. The executor now tells the simulated world
// which visit is under way.
TEST_F(Faults, AFaultOnARevisitActsOnTheRevisitOnly) {
  mission_ = "revisit_tour.yaml";
  const DryRunResult r = run_fault("w_revisit_frames_lost.yaml", 3);
  EXPECT_EQ(report_target(r.report, kFaulted).at("outcome").get<std::string>(), "projected");
  EXPECT_EQ(join(outcome_chain(r.events, "rabbit-again")),
            "navigate:succeeded > aim:succeeded > capture:no_frame > capture:no_frame > "
            "capture:no_frame > skip_target");
  const Json& again = report_target(r.report, "rabbit-again");
  EXPECT_EQ(again.at("outcome").get<std::string>(), "skipped");
  EXPECT_EQ(again.at("reason").get<std::string>().rfind("no_frame:", 0), 0u) << again.dump();
}

// The target is gone: align finds no points where it should stand, re-aims twice (aim's
// retries), finds nothing again and the target is skipped with align's reason.
TEST_F(Faults, TargetMissingReAimsThenSkips) {
  const DryRunResult r = run_fault("w_target_missing.yaml", 3);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > skip_target");
  expect_skipped(r, "^no_target: 0 points within [0-9.]+ m of the expected target");
  EXPECT_EQ(report_target(r.report, kFaulted).at("retries").get<long long>(), 2);
}

// A board hangs between the stand-off pose and the rabbit (above the laser plane, so navigation
// reaches the stand-off pose): the camera sees the board's edge, too few points where the
// rabbit should be, and the target is skipped after re-aiming rather than projected on the board.
TEST_F(Faults, OccluderIsNotProjectedOn) {
  const DryRunResult r = run_fault("w_occluder.yaml", 3);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > skip_target");
  expect_skipped(r, "^no_target: [0-9]+ points within [0-9.]+ m of the expected target");
}

// A box on the stand-off pose: the laser sees it, navigation makes no progress and gives up
// after its blocked_s; the tour goes on.
// Blocked, the rabbit is left for later; the sign is projected; blocked again, it is skipped.
TEST_F(Faults, BlockedPathSkipsTheTarget) {
  const DryRunResult r = run_fault("w_blocked_path.yaml", 3);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)), "navigate:blocked > navigate:blocked");
  expect_skipped(r,
                 "^blocked: no progress for 15(\\.0+)? s \\(again, after it was left for "
                 "later\\)$");
}

// The robot is carried 2 m away as it stops at the rabbit (odometry does not notice). What the
// system does (seed 11): nothing notices while it stands there, so aim, capture and align look
// where the rabbit is not, find nothing and skip it (align's no_target is what catches the
// kidnap). On the way to the sign localization recovers, by itself as the scans pull the
// particles back or through navigate's lost and a relocalize, and the sign is projected. Safe
// throughout: nothing is projected anywhere but on its target, and the skip says why.
TEST_F(Faults, KidnappedRobotSkipsTheTargetAndRecoversByTheNext) {
  const DryRunResult r = dry_run("w_kidnap.yaml", "run");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > "
            "aim:succeeded > capture:succeeded > align:no_target > skip_target");
  expect_skipped(r, "^no_target: 0 points within [0-9.]+ m of the expected target");

  const auto next = outcome_chain(r.events, kNext);
  const std::string tail =
      "aim:succeeded > capture:succeeded > align:succeeded > calibrate:succeeded > verify:verified "
      "> project:succeeded > "
      "next:succeeded > finish";
  EXPECT_TRUE(join(next) == "navigate:succeeded > " + tail ||
              join(next) == "navigate:lost > relocalize:succeeded > navigate:succeeded > " + tail)
      << join(next);
  const Json& sign = report_target(r.report, kNext);
  EXPECT_EQ(sign.at("outcome").get<std::string>(), "projected") << sign.dump();
  EXPECT_LT(sign.at("localization_error").at("trans_m").get<double>(), 0.1) << sign.dump();
  EXPECT_LT(sign.at("projection_error_mm").at("after_align").get<double>(), 20.0) << sign.dump();
}

// The depth camera disconnects as capture asks for its first frame at the rabbit: capture fails
// on the driver error and the target is skipped with the driver's message; at the sign the
// (simulated) camera works again and the tour goes on.
// On this seed the sign's outline sees a Model Point 1.62 mm off and the error reads 1.73 mm,
// both over half the 3 mm tolerance: verify makes the move and looks again (1.10 mm), which
// costs one retry; the referee's error is then 0.51 mm.
TEST_F(Faults, CameraDisconnectMidCaptureSkips) {
  const DryRunResult r =
      run_fault("w_camera_disconnect.yaml", 3,
                "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
                "calibrate:succeeded > verify:misaligned > verify:verified > project:succeeded > "
                "next:succeeded > finish");
  EXPECT_LE(
      report_target(r.report, kNext).at("projection_error_mm").at("after_align").get<double>(),
      3.0);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:failed > skip_target");
  expect_skipped(r, "^failed: depth camera: simulated depth camera: device disconnected$");
}

// The lamp fails at the first show: project fails, the projector is never lit on the rabbit,
// the target is skipped with the driver's message.
TEST_F(Faults, ProjectorFailureSkips) {
  const DryRunResult r = run_fault("w_projector_failure.yaml", 3);
  EXPECT_EQ(join(outcome_chain(r.events, kFaulted)),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "calibrate:failed > skip_target");
  // The lamp fails at the first show: the structured light's first pattern.
  expect_skipped(r, "^failed: start failed: simulated projector: lamp failure$");
  for (const Json& e : read_jsonl(r.dir / "sim_projector_log.jsonl")) {
    EXPECT_FALSE(e.at("event").get<std::string>() == "show" && e.at("target").is_string() &&
                 e.at("target").get<std::string>() == kFaulted)
        << e.dump();
  }
}

}  // namespace
}  // namespace projtour::integration
