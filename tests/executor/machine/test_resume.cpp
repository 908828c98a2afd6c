// Interrupt a tour in each step of the second target, write the checkpoint, resume from it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "executor_harness.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/run/atomic_file.hpp"
#include "projtour/run/report.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::testing {
namespace {

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
    checkpoint.done_against.assign(checkpoint.done.size(), TargetIdentity{});
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

// The harness's mission with a model file of each target's own, as a run's mission has: the
// checkpoint records what each done target was done against, and a resume checks it.
class ResumeAgainstTheMission : public ::testing::Test {
 protected:
  void SetUp() override {
    for (auto& t : harness_.mission.targets) {
      t.model = scratch_ / (t.id + ".ply");
      write_model(t.model, "ply " + t.id + "\n");
      t.T_map_model.translation() = Eigen::Vector3d(1.0, 2.0, 0.5);
    }
  }
  static void write_model(const std::filesystem::path& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
  }
  // rabbit and pillar projected, against the mission as it is now.
  Checkpoint first_two_done() const {
    Checkpoint c;
    c.mission = harness_.mission.name;
    const std::vector<TargetIdentity> now = identify_targets(harness_.mission);
    for (std::size_t i = 0; i < 2; ++i) {
      TargetRecord r;
      r.index = i;
      r.id = harness_.mission.targets[i].id;
      r.outcome = "projected";
      c.done.push_back(r);
      c.done_against.push_back(now[i]);
    }
    return c;
  }
  // Through the file, as --resume reads it, against the mission as it is then: the notes.
  std::vector<std::string> resume(Checkpoint& c) {
    const auto file = scratch_ / "checkpoint.json";
    write_file_atomically(file, dump_json(checkpoint_to_json(c), 2));
    c = read_checkpoint(file, harness_.mission);
    return drop_changed_targets(c, identify_targets(harness_.mission));
  }
  // Resumes `c`, expects `note` alone and `kept` still done, and runs the tour from there:
  // exactly the visits of `revisited`, then sign.
  void expect_revisited(Checkpoint c, const std::string& note, const std::string& kept,
                        const std::string& revisited) {
    EXPECT_EQ(resume(c), std::vector<std::string>{note});
    ASSERT_EQ(c.done.size(), 1u);
    EXPECT_EQ(c.done[0].id, kept);
    expect_visits(c, revisited);
  }
  // Runs the tour from `c` and expects exactly the visits of `revisited`, then sign.
  void expect_visits(const Checkpoint& c, const std::string& revisited) {
    harness_.load_default();
    harness_.build();
    harness_.executor->restore(c.done, std::nullopt);
    EXPECT_EQ(harness_.run(), TourOutcome::completed);
    ASSERT_SEQUENCE(harness_.recorder,
                    seq({{"enter tour"}, happy_visit(revisited), happy_visit("sign"), kTourEnd}));
    EXPECT_EQ(harness_.executor->records().size(), 3u);
  }

  const test::TempDir scratch_;
  Harness harness_;
};

// Regression: a target moved 24 m under the same id counted as done.
TEST_F(ResumeAgainstTheMission, MovedTargetIsVisitedAgainWithANote) {
  Checkpoint c = first_two_done();
  harness_.mission.targets[0].T_map_model.translation().x() += 24.0;
  harness_.mission.targets[1].T_map_model.translation().y() += 0.0005;  // within the tolerance
  expect_revisited(c,
                   "target \"rabbit\" visited again: its pose on the map moved 24.000 m since the "
                   "checkpoint",
                   "pillar", "rabbit");
}

TEST_F(ResumeAgainstTheMission, TurnedTargetIsVisitedAgainWithANote) {
  Checkpoint c = first_two_done();
  const auto turn = [](double deg) {
    return Eigen::AngleAxisd(deg * EIGEN_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  };
  harness_.mission.targets[0].T_map_model.linear() = turn(0.005);  // within the tolerance
  harness_.mission.targets[1].T_map_model.linear() = turn(-2.0);
  expect_revisited(c,
                   "target \"pillar\" visited again: its pose on the map turned 2.000 deg since "
                   "the checkpoint",
                   "rabbit", "pillar");
}

TEST_F(ResumeAgainstTheMission, ChangedModelIsVisitedAgainWithANote) {
  Checkpoint c = first_two_done();
  TargetSpec& rabbit = harness_.mission.targets[0];
  write_model(rabbit.model, "ply rabbit, scanned again\n");
  // pillar's model moved to another file, byte for byte the same: the same model.
  TargetSpec& pillar = harness_.mission.targets[1];
  pillar.model = scratch_ / "moved_pillar.ply";
  write_model(pillar.model, "ply pillar\n");
  const std::vector<std::string> notes = resume(c);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0].rfind("target \"rabbit\" visited again: its model changed (", 0), 0u)
      << notes[0];
  EXPECT_NE(notes[0].find(", 11 bytes, fnv1a64 "), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find(", 26 bytes, fnv1a64 "), std::string::npos) << notes[0];
  ASSERT_EQ(c.done.size(), 1u);
  EXPECT_EQ(c.done[0].id, "pillar");
  expect_visits(c, "rabbit");
}

TEST(TargetIdentity, ModelIsIdentifiedBySizeAndFnv1aOfItsBytes) {
  const test::TempDir scratch;
  TargetSpec t;
  t.model = scratch / "m.ply";
  std::ofstream(t.model, std::ios::binary) << "a";
  const TargetIdentity id = identify_target(t);
  EXPECT_EQ(id.model_bytes, 1u);
  EXPECT_EQ(id.model_fnv1a64, 0xaf63dc4c8601ec8cull);  // FNV-1a 64 of "a", the published value
  t.model = scratch / "missing.ply";
  EXPECT_THROW(identify_target(t), std::runtime_error);
}

}  // namespace
}  // namespace projtour::testing
