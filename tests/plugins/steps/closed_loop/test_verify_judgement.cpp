// verify's judgement, one test per outcome it can reach (nine ways), from figures alone: each
// starts from a measurement that verifies and changes the one figure that decides otherwise.
#include <gtest/gtest.h>

#include <string>

#include "step_names.hpp"
#include "verify_judgement.hpp"

namespace projtour::closed_loop {
namespace {

// A measurement within every bound: a clear outline that moves nothing, 1 mm off at each dot,
// all the light on the target, a fit that agrees with itself.
VerifyMeasured good() {
  VerifyMeasured m;
  m.on_target_fraction = 0.99;
  m.in_front_fraction = 0.0;
  m.outline_clear = true;
  m.outline_text = "the outline seen 0.2 mm from the aligned pose";
  m.dots_seen = 4;
  m.observed_error_mm = 1.0;
  m.corner_error_mm = {0.9, 1.0, 1.1, 1.0};
  m.at_pose_mm = 1.0;
  m.moves_mm = 0.2;
  m.spread_model_point_mm = 0.3;
  m.spread_blocks = 12;
  m.spread_matches = 4000;
  return m;
}

const VerifyCriteria kCriteria{3.0, 0.95, 4.0};

bool says(const VerifyJudgement& j, const std::string& what) {
  return j.reason.find(what) != std::string::npos;
}

TEST(VerifyJudgement, Verified_WhenTheDotsAreWithinTheToleranceAndTheLightOnTheTarget) {
  const VerifyJudgement j = judge_verify(good(), kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kVerified);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_EQ(j.reason,
            "observed error 1.00 mm (corners 0.9, 1.0, 1.1, 1.0 mm), the outline seen 0.2 mm from "
            "the aligned pose, the fit's spread 0.30 mm over 12 blocks within 3.0 mm; 99.0 % of "
            "the light on the target, 0.0 % in front of it");
}

TEST(VerifyJudgement, Misaligned_WhenTheOutlineSeesAGrossSlideBeforeAnythingElse) {
  VerifyMeasured m = good();
  m.outline_gross = true;
  m.outline_text = "the outline seen 9.0 mm from the aligned pose";
  m.on_target_fraction = 0.5;  // would be occluded: the gross slide is judged first
  m.in_front_fraction = 0.5;
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kMisaligned);
  EXPECT_TRUE(j.correct_pose);
  EXPECT_EQ(j.reason,
            "the outline seen 9.0 mm from the aligned pose; the pose slides with the outline; "
            "50.0 % of the light on the target, 50.0 % in front of it");
}

TEST(VerifyJudgement, Occluded_WhenLessLightLandsOnTheTargetAndAsMuchInFrontAsElsewhere) {
  VerifyMeasured m = good();
  m.on_target_fraction = 0.6;
  m.in_front_fraction = 0.2;  // 0.2 in front, 0.2 elsewhere: something stands in the beam
  m.dots_seen = 2;            // would be not_seen: the occluder is judged first
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kOccluded);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_TRUE(says(j,
                   "something stands in the beam: 60.0 % of the light on the target, 20.0 % "
                   "in front of it (at least 95 % needed)"))
      << j.reason;
}

TEST(VerifyJudgement, NotSeen_WhenADotWasNotFound) {
  VerifyMeasured m = good();
  m.dots_seen = 3;
  m.unseen = "2";
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kNotSeen);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_TRUE(says(j, "did not find Model Point 2's dot")) << j.reason;
}

TEST(VerifyJudgement, Uncertain_WhenTooFewPartsOfTheModelMatchedTheDepth) {
  VerifyMeasured m = good();
  m.spread_blocks = 3;
  m.spread_matches = 70;
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kUncertain);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_TRUE(says(j, "too little of the model matched the depth (70 points in 3 parts"))
      << j.reason;
}

TEST(VerifyJudgement, Uncertain_WhenTheFitsSpreadTimesSpreadSigmasExceedsTheTolerance) {
  VerifyMeasured m = good();
  m.spread_model_point_mm = 0.8;  // 4 x 0.8 = 3.2 mm > 3 mm
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kUncertain);
  EXPECT_TRUE(says(j,
                   "puts the Model Points 0.80 mm apart (one standard deviation; 4 of them, "
                   "3.2 mm, exceed the tolerance of 3.0 mm)"))
      << j.reason;
  m.spread_model_point_mm = 0.75;  // 3.0 mm: not beyond
  EXPECT_STREQ(judge_verify(m, kCriteria).outcome, outcome::kVerified);
}

TEST(VerifyJudgement, Misaligned_WhenAClearOutlineMovesAModelPointMoreThanHalfTheTolerance) {
  VerifyMeasured m = good();
  m.moves_mm = 1.8;           // more than 1.5 mm
  m.observed_error_mm = 2.0;  // reads more than half the tolerance, within it
  m.at_pose_mm = 2.5;         // the light lands within the tolerance of the aligned pose
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kMisaligned);
  EXPECT_TRUE(j.correct_pose);
  EXPECT_TRUE(says(j,
                   " is within the tolerance of 3.0 mm, the outline moves a Model Point 1.80 "
                   "mm, the light 2.50 mm from the aligned pose's corners; the pose slides "
                   "with the outline; "))
      << j.reason;
  // A faint outline does not move the pose: the figures are then judged as they stand.
  m.outline_clear = false;
  EXPECT_STREQ(judge_verify(m, kCriteria).outcome, outcome::kVerified);
}

TEST(VerifyJudgement, OutOfTolerance_WhenTheObservedErrorExceedsTheTolerance) {
  VerifyMeasured m = good();
  m.observed_error_mm = 3.4;
  m.at_pose_mm = 3.4;  // the light misses the aligned pose too: the pose is not what misses
  m.moves_mm = 1.8;
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kOutOfTolerance);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_TRUE(says(j, "observed error 3.40 mm")) << j.reason;
  EXPECT_TRUE(says(j, " exceeds the tolerance of 3.0 mm; 99.0 % of the light")) << j.reason;
}

TEST(VerifyJudgement, OutOfTolerance_WhenTheLightSpillsOffTheTarget) {
  VerifyMeasured m = good();
  m.on_target_fraction = 0.9;  // 10 % off, none in front: spilt past the target, not occluded
  m.in_front_fraction = 0.0;
  const VerifyJudgement j = judge_verify(m, kCriteria);
  EXPECT_STREQ(j.outcome, outcome::kOutOfTolerance);
  EXPECT_FALSE(j.correct_pose);
  EXPECT_TRUE(says(j,
                   "the light spills off the target: 90.0 % of the light on the target, 0.0 % "
                   "in front of it (at least 95 % needed); observed error 1.00 mm"))
      << j.reason;
}

}  // namespace
}  // namespace projtour::closed_loop
