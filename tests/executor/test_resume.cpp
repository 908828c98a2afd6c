// Interrupt a tour in each step of the second target, write the checkpoint, resume from it.
#include <gtest/gtest.h>

#include <filesystem>

#include "executor_harness.hpp"
#include "projtour_executor/atomic_file.hpp"
#include "projtour_executor/json_io.hpp"
#include "projtour_executor/report.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::testing {
namespace {

const std::vector<std::string> kTourEnd = {"outcome visit done", "transition visit done -> done",
                                           "enter done",         "exit done",
                                           "exit tour",          "outcome tour done"};

class ResumeAfterInterruption : public ::testing::TestWithParam<std::string> {};

TEST_P(ResumeAfterInterruption, RestartsTheInterruptedTargetFromNavigate) {
  const std::string step = GetParam();
  const test::TempDir scratch;
  const std::filesystem::path dir = scratch.path();

  Checkpoint checkpoint;
  {
    Harness first;
    first.script(step, "succeeded", 5);  // long enough to be interrupted inside
    first.load_default();
    first.build();
    ASSERT_TRUE(first.step_until("visit/" + step, "pillar"));
    first.executor->step();
    first.executor->request_cancel();
    ASSERT_EQ(first.run(), TourOutcome::interrupted);
    const auto lines = first.recorder.lines();
    ASSERT_EQ(lines.back(), "exit tour");
    ASSERT_EQ(lines[lines.size() - 4], "outcome visit/" + step + " cancelled @pillar");
    checkpoint.mission = first.mission.name;
    checkpoint.seed = 7;
    checkpoint.mission_s = first.clock.now_s();
    checkpoint.done = first.executor->records();
    checkpoint.current_target = "pillar";
    write_file_atomically(dir / "checkpoint.json", dump_json(checkpoint_to_json(checkpoint), 2));
  }
  ASSERT_EQ(checkpoint.done.size(), 1u);
  EXPECT_EQ(checkpoint.done[0].id, "rabbit");

  Harness second;
  const Checkpoint read = read_checkpoint(dir / "checkpoint.json", second.mission);
  EXPECT_EQ(read.seed, 7u);
  EXPECT_EQ(read.current_target, std::optional<std::string>("pillar"));
  EXPECT_DOUBLE_EQ(read.mission_s, checkpoint.mission_s);
  second.clock.set(read.mission_s);
  second.load_default();
  second.build();
  second.executor->restore(read.done, std::size_t{1});
  EXPECT_EQ(second.run(), TourOutcome::completed);
  ASSERT_SEQUENCE(second.recorder,
                  seq({{"enter tour"}, happy_visit("pillar"), happy_visit("sign"), kTourEnd}));
  ASSERT_EQ(second.executor->records().size(), 3u);
  EXPECT_EQ(second.executor->records()[0].id, "rabbit");
  EXPECT_GT(second.recorder.events.front().t_s, 0.0);  // mission time carries on
}

// An interruption in `next` comes after the content was shown: see the test below.
INSTANTIATE_TEST_SUITE_P(EachStep, ResumeAfterInterruption,
                         ::testing::Values("navigate", "aim", "capture", "align", "project"));

// Regression: a SIGINT while `next` stowed the head threw the finished visit away and --resume
// projected that target a second time. Once `project` succeeded the visit counts as projected.
TEST(Resume, InterruptedInNextAfterProjectingIsNotProjectedAgain) {
  Checkpoint checkpoint;
  {
    Harness first;
    first.script("next", "succeeded", 5);
    first.load_default();
    first.build();
    ASSERT_TRUE(first.step_until("visit/next", "pillar"));
    first.executor->step();
    first.executor->request_cancel();
    ASSERT_EQ(first.run(), TourOutcome::interrupted);
    EXPECT_FALSE(first.executor->current_target().has_value());
    checkpoint.done = first.executor->records();
  }
  ASSERT_EQ(checkpoint.done.size(), 2u);
  EXPECT_EQ(checkpoint.done[1].id, "pillar");
  EXPECT_EQ(checkpoint.done[1].outcome, "projected");

  Harness second;
  second.load_default();
  second.build();
  second.executor->restore(checkpoint.done, std::nullopt);
  EXPECT_EQ(second.run(), TourOutcome::completed);
  ASSERT_SEQUENCE(second.recorder, seq({{"enter tour"}, happy_visit("sign"), kTourEnd}));
}

TEST(Resume, EverythingDoneFinishesAtOnce) {
  Harness h({"rabbit"});
  h.load_default();
  h.build();
  TargetRecord done;
  done.index = 0;
  done.id = "rabbit";
  done.outcome = "projected";
  h.executor->restore({done}, std::nullopt);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_SEQUENCE(h.recorder, seq({{"enter tour"}, kTourEnd}));
}

TEST(Resume, CheckpointOfAnotherMissionIsRefused) {
  const test::TempDir scratch;
  const auto file = scratch / "checkpoint.json";
  Checkpoint c;
  c.mission = "elsewhere";
  write_file_atomically(file, dump_json(checkpoint_to_json(c)));
  Harness h;
  try {
    read_checkpoint(file, h.mission);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("written by mission \"elsewhere\""), std::string::npos);
  }
}

TEST(Resume, SkippedRecordsKeepTheirReasonThroughTheCheckpoint) {
  TargetRecord r;
  r.index = 2;
  r.id = "sign";
  r.outcome = "skipped";
  r.reason = "poor_fit: inliers 0.2";
  r.retries = 3;
  r.measurements.projected_s = 0.0;
  const TargetRecord back = parse_json(dump_json(Json(r)), "record").get<TargetRecord>();
  EXPECT_EQ(back.id, "sign");
  EXPECT_EQ(back.reason, r.reason);
  EXPECT_EQ(back.retries, 3);
  ASSERT_TRUE(back.measurements.projected_s.has_value());
  EXPECT_EQ(*back.measurements.projected_s, 0.0);
  EXPECT_EQ(dump_json(Json(back)), dump_json(Json(r)));
}

}  // namespace
}  // namespace projtour::testing
