// The closed loop (issue 13): the real `projtour run --dry-run` on the two-target integration
// tour, the robot watching its own light with the simulated colour camera. The referee's
// projection_error_mm is never shown to the robot; these tests hold the robot's own figures
// against it.
#include <algorithm>
#include <cmath>
#include <regex>

#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

using ClosedLoop = DryRunTest;

double after_align_mm(const Json& t) {
  return t.at("projection_error_mm").at("after_align").get<double>();
}

// The message of the visit's first `step` outcome ("" when the step never ended).
std::string first_message(const std::vector<Json>& events, const std::string& target,
                          const std::string& step) {
  for (const StepOutcome& s : step_outcomes(events, target)) {
    if (s.step == step) return s.message;
  }
  return "";
}

// The sign was skipped `occluded` because something stands in its beam; its record.
const Json& sign_skipped_occluded(const DryRunResult& r) {
  EXPECT_EQ(r.exit_code, 3) << r.err;
  const Json& t = report_target(r.report, "open-day-sign");
  EXPECT_EQ(t.at("outcome").get<std::string>(), "skipped") << t.dump();
  EXPECT_TRUE(std::regex_search(t.at("reason").get<std::string>(),
                                std::regex("^occluded: .*something stands in the beam")))
      << t.dump();
  return t;
}

// A 10 mm / 1 deg calibration drift (the robot file does not know it) is measured on each
// target by structured light; the content still lands within tolerance and the robot's
// observed error agrees with the referee's.
TEST_F(ClosedLoop, CalibrationDriftIsMeasuredAndCorrected) {
  const DryRunResult r = dry_run("w_calibration_drift.yaml", "run");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* id : {"rabbit", "open-day-sign"}) {
    const Json& t = report_target(r.report, id);
    SCOPED_TRACE(id);
    ASSERT_EQ(t.at("outcome").get<std::string>(), "projected") << t.dump();
    // The rabbit's faint outline moves its Model Points 1.6 mm with the light read 2.6 mm off:
    // the pose moves and is looked at again before anything is shown.
    const std::string second_look = std::string(id) == "rabbit" ? "verify:misaligned > " : "";
    EXPECT_EQ(join(outcome_chain(r.events, id)),
              "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
              "calibrate:succeeded > " +
                  second_look + "verify:verified > project:succeeded > next:succeeded > finish");
    EXPECT_LE(after_align_mm(t), 3.0) << t.dump();
    EXPECT_LE(t.at("projection_error_area_mm").at("max").get<double>(), 3.5) << t.dump();
    EXPECT_LE(std::abs(t.at("observed_error_mm").get<double>() - after_align_mm(t)), 2.0)
        << t.dump();
    const Json& c = t.at("calibration");
    EXPECT_TRUE(c.at("adopted").get<bool>());
    EXPECT_LE(c.at("sequence_s").get<double>(), 1.5);
    EXPECT_GE(c.at("inliers").get<int>(), 100);
    // The first target's measurement moves the content by about the drift; the second's
    // confirms the first's.
    if (std::string(id) == "rabbit") {
      EXPECT_GT(c.at("change_mm").get<double>(), 5.0) << c.dump();
    } else {
      EXPECT_LT(c.at("change_mm").get<double>(), 3.0) << c.dump();
    }
    EXPECT_EQ(t.at("light_off_target_fraction").get<double>(), 0.0);
  }
  // The calibration a person can adopt: a projector fragment of the robot file.
  const std::string fragment = read_text(r.dir / "calibration.yaml");
  EXPECT_TRUE(
      std::regex_search(fragment, std::regex("\nprojector:\n  mount: tilt\n  pose: \\{x: ")))
      << fragment;
  EXPECT_NE(fragment.find("open-day-sign"), std::string::npos) << fragment;
}

// Verification out of tolerance, then corrected: the machine goes from align straight to verify,
// which sees the drift (the corners land about 2 cm off) and sends the visit to calibrate; the
// second verification moves the pose with the rabbit's outline, the third passes, and only then
// is the content shown.
TEST_F(ClosedLoop, VerificationOutOfToleranceCalibratesAndTriesAgain) {
  mission_ = "verify_first_tour.yaml";
  const DryRunResult r = dry_run("w_calibration_drift.yaml", "run");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(join(outcome_chain(r.events, "rabbit")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "verify:out_of_tolerance > calibrate:succeeded > verify:misaligned > "
            "verify:verified > project:succeeded > next:succeeded > finish");
  const std::string first = first_message(r.events, "rabbit", "verify");
  EXPECT_TRUE(
      std::regex_search(first, std::regex("observed error [0-9.]+ mm .* exceeds the tolerance "
                                          "of 3.0 mm")))
      << first;
  const Json& t = report_target(r.report, "rabbit");
  EXPECT_EQ(t.at("retries").get<int>(), 2);
  EXPECT_LE(after_align_mm(t), 3.0) << t.dump();
  // The sign is verified with the rabbit's calibration: no second correction needed.
  EXPECT_EQ(join(outcome_chain(r.events, "open-day-sign")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "verify:verified > project:succeeded > next:succeeded > finish");
}

// Regression: ICP settled on the sign's own plane 87 mm along it (the guess 0.2 m / 20 deg off),
// and the camera saw its dots land where that pose put them; on the demo tour such a visit was
// reported projected 43 mm off. The sign's outline in the colour image shows the slide: verify
// slides the pose, looks again (the slide is to first order: twice), and only then projects.
TEST_F(ClosedLoop, SignSlidAlongItsPlaneByIcpIsCaughtByItsOutline) {
  mission_ = "slid_sign_tour.yaml";
  const DryRunResult r = dry_run("w_slid_sign.yaml", "run");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(join(outcome_chain(r.events, "open-day-sign")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "calibrate:succeeded > verify:misaligned > verify:misaligned > verify:verified > "
            "project:succeeded > next:succeeded > finish");
  const std::string first = first_message(r.events, "open-day-sign", "verify");
  EXPECT_TRUE(
      std::regex_search(first, std::regex("the outline seen [0-9.]+ mm from the aligned pose")))
      << first;
  const Json& t = report_target(r.report, "open-day-sign");
  EXPECT_GT(t.at("projection_error_mm").at("before_align").get<double>(), 40.0) << t.dump();
  EXPECT_LE(after_align_mm(t), 3.0) << t.dump();
  EXPECT_LE(std::abs(t.at("observed_error_mm").get<double>() - after_align_mm(t)), 1.0) << t.dump();
}

// Regression: a pillar 0.2 m nearer than the map has it; re-aimed at its aligned pose its
// content still did not fit the projector image from the believed stand-off, and the visit was
// skipped off_screen. aim says reapproach; navigate drives to the stand-off from the aligned
// pose, as much farther as the content needs; the visit goes on.
TEST_F(ClosedLoop, PillarNearerThanTheMapIsReapproached) {
  mission_ = "pillar_tour.yaml";
  const DryRunResult r = dry_run("w_pillar_nearer.yaml", "run");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string chain = join(outcome_chain(r.events, "pillar-east"));
  EXPECT_TRUE(std::regex_search(
      chain, std::regex("aim:reapproach > navigate:succeeded > aim:succeeded > capture:succeeded "
                        "> align:succeeded > calibrate:succeeded > verify:verified > "
                        "project:succeeded > next:succeeded > finish$")))
      << chain;
  const Json& t = report_target(r.report, "pillar-east");
  EXPECT_LE(after_align_mm(t), 3.0) << t.dump();
}

// A rough scan (4 mm rms): on the bunny the camera sees the dots land where the pose put them,
// but the fit's parts disagree on the pose; verify says uncertain and the visit is skipped with
// the reason rather than projected unvouched for. The sign's fit agrees with itself.
TEST_F(ClosedLoop, RoughModelIsUncertainNeverProjectedUnvouched) {
  const DryRunResult r = dry_run("w_rough_model.yaml", "run");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  const Json& rabbit = report_target(r.report, "rabbit");
  EXPECT_EQ(rabbit.at("outcome").get<std::string>(), "skipped") << rabbit.dump();
  EXPECT_TRUE(std::regex_search(rabbit.at("reason").get<std::string>(),
                                std::regex("^uncertain: .*does not fit the surface well enough")))
      << rabbit.dump();
  EXPECT_EQ(join(outcome_chain(r.events, "rabbit")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "calibrate:succeeded > verify:uncertain > skip_target");
  const Json& sign = report_target(r.report, "open-day-sign");
  EXPECT_EQ(sign.at("outcome").get<std::string>(), "projected") << sign.dump();
  EXPECT_LE(after_align_mm(sign), 3.0) << sign.dump();
}

// Regression: with a rough scan the sign-south model's fit was turned about 0.2 deg about its own
// normal; the outline's shift did not hold the turn, verify measured the light 2.1 mm from the
// Model Points it believed, and the visit was reported projected at 3.4 mm of real error. The
// outline's turn now moves each Model Point: the first look sees the pose move a Model Point
// beyond the tolerance, the pose turns with the outline, the second look passes, and no visit of
// the tour is projected beyond its tolerance. A second regression: with the coarser ICP schedule
// of issue 18 the first look read 2.6 mm, within the tolerance, while the referee measured
// 3.1 mm: a move the outline sees beyond the tolerance is made however the error reads.
TEST_F(ClosedLoop, RoughSignTurnedAboutItsNormalIsCaughtByItsOutline) {
  mission_ = "../../../missions/demo_tour.yaml";
  const DryRunResult r = dry_run("w_rough_sign_turned.yaml", "run");
  ASSERT_TRUE(r.report.contains("targets")) << r.err;
  for (const Json& t : r.report.at("targets")) {
    if (t.at("outcome").get<std::string>() != "projected") continue;
    EXPECT_LE(after_align_mm(t), 3.0) << t.dump();
  }
  const std::string chain = join(outcome_chain(r.events, "sign-south"));
  EXPECT_TRUE(std::regex_search(
      chain, std::regex("calibrate:succeeded > verify:misaligned > verify:verified > "
                        "project:succeeded")))
      << chain;
  const std::string first = first_message(r.events, "sign-south", "verify");
  EXPECT_TRUE(std::regex_search(first, std::regex("turned 0\\.[12][0-9] deg, 2 directions fixed")))
      << first;
  EXPECT_TRUE(std::regex_search(
      first,
      std::regex("the tolerance of 3.0 mm, the outline moves a Model Point [3-9]\\.[0-9]+ mm")))
      << first;
  const Json& sign = report_target(r.report, "sign-south");
  EXPECT_EQ(sign.at("outcome").get<std::string>(), "projected") << sign.dump();
  EXPECT_LE(std::abs(sign.at("observed_error_mm").get<double>() - after_align_mm(sign)), 2.0)
      << sign.dump();
}

// Regression: a thin pole 0.6 m in front of the sign caught 14 % of the content's light and the
// visit was still reported projected. Then the beam guard saw it as soon as the structured light
// went up and the visit ended blocked_beam, the outcome of someone walking into the light. The
// pole stands in the depth frame the sign was captured in: nothing is lit while a fresh depth
// frame still shows it there, each look ends occluded, a wait, a look again, then skipped with
// the reason (the sign is the tour's first target; the rabbit is projected after it).
TEST_F(ClosedLoop, PoleInFrontOfTheSignIsOccludedAndNeverLit) {
  const DryRunResult r = dry_run("w_pole.yaml", "run");
  EXPECT_EQ(report_target(r.report, "rabbit").at("outcome").get<std::string>(), "projected");
  const Json& t = sign_skipped_occluded(r);
  EXPECT_TRUE(std::regex_search(
      t.at("reason").get<std::string>(),
      std::regex("^occluded: .*something stands in the beam \\([0-9]+ readings, 0\\.[0-9]+ m from "
                 "the projector; [0-9]+ when the target was captured\\): the verification "
                 "pattern not shown")))
      << t.dump();
  EXPECT_EQ(join(outcome_chain(r.events, "open-day-sign")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "calibrate:occluded > wait:succeeded > verify:occluded > wait:succeeded > "
            "verify:occluded > skip_target");
  EXPECT_GT(shows_on(r.dir, ""), 0) << "the rabbit's light is logged";
  EXPECT_EQ(shows_on(r.dir, "open-day-sign"), 0) << "the projector was lit on the pole";
}

// Regression: a dropped depth frame (no readings) is clear of everything, and the look before
// lighting took one as the pole gone and lit it. Half the sign's depth frames are dropped here:
// only a frame with readings decides, and the pole is never lit.
TEST_F(ClosedLoop, Regression_ADroppedDepthFrameNeverLightsThePole) {
  const DryRunResult r = dry_run("w_pole_dropout.yaml", "run");
  sign_skipped_occluded(r);
  const std::string chain = join(outcome_chain(r.events, "open-day-sign"));
  EXPECT_NE(chain.find("calibrate:occluded"), std::string::npos) << chain;
  EXPECT_EQ(chain.find("blocked_beam"), std::string::npos) << chain;
  EXPECT_EQ(shows_on(r.dir, "open-day-sign"), 0) << "the projector was lit on the pole";
}

// A pole just before the sign's face, within the beam guard's margin: the colour camera sees
// the light land in front of the target: occluded, a wait, a look again, then skipped.
TEST_F(ClosedLoop, PoleRightBeforeTheSignIsOccluded) {
  const DryRunResult r = dry_run("w_pole_close.yaml", "run");
  const Json& t = sign_skipped_occluded(r);
  EXPECT_EQ(join(outcome_chain(r.events, "open-day-sign")),
            "navigate:succeeded > aim:succeeded > capture:succeeded > align:succeeded > "
            "calibrate:succeeded > verify:occluded > wait:succeeded > verify:occluded > "
            "wait:succeeded > verify:occluded > skip_target");
  EXPECT_LT(t.at("observed_light_on_target").get<double>(), 0.95);
}

// A failed decode: daylight floods the rabbit's corner and the Gray code drowns in it. The
// calibrate step says so (too_few_points, keeping the calibration believed so far), the machine
// re-captures and tries again, then lets verify judge with the old calibration; verify cannot see
// its dots either, and the visit is skipped with the reason -- never projected unverified.
TEST_F(ClosedLoop, FailedDecodeRecapturesThenVerifiesWithTheOldCalibration) {
  const DryRunResult r = dry_run("w_daylight.yaml", "run");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  const auto chain = outcome_chain(r.events, "rabbit");
  const std::string joined = join(chain);
  EXPECT_TRUE(std::regex_search(joined, std::regex("^navigate:succeeded > aim:succeeded > "
                                                   "capture:succeeded > align:succeeded > "
                                                   "calibrate:too_few_points > capture:succeeded")))
      << joined;
  EXPECT_NE(joined.find("verify:"), std::string::npos) << joined;
  EXPECT_EQ(joined.find("project:"), std::string::npos) << joined;
  for (const StepOutcome& s : step_outcomes(r.events, "rabbit")) {
    if (s.step == "calibrate") {
      EXPECT_TRUE(
          std::regex_search(s.message, std::regex("keeping the calibration believed so far")))
          << s.message;
    }
  }
  const Json& t = report_target(r.report, "rabbit");
  EXPECT_EQ(t.at("outcome").get<std::string>(), "skipped") << t.dump();
  EXPECT_FALSE(t.at("calibration").at("adopted").get<bool>()) << t.dump();
  EXPECT_EQ(report_target(r.report, "open-day-sign").at("outcome").get<std::string>(), "projected");
}

}  // namespace
}  // namespace projtour::integration
