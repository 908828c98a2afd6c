// All day: a schedule's rounds (rounds, until, the pause between them), targets passed over
// outside their hours, content lists rotated per visit or per round, and a resume that goes on
// with the round it was in, each target of that round projected exactly once.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <utility>

#include "executor_harness.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/record/checkpoint.hpp"
#include "projtour/run/atomic_file.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::testing {
namespace {

constexpr double kTen = 10 * 3600.0;  // 10:00

// The tour as an operator reads it: rounds, visits and targets passed over, in order.
std::vector<std::string> tour_lines(const Recorder& r) {
  std::vector<std::string> out;
  for (const ExecutorEvent& e : r.events) {
    const std::string round = " r" + std::to_string(e.round);
    if (e.type == EventType::round) {
      out.push_back("round " + std::to_string(e.round) + " " + e.outcome);
    } else if (e.type == EventType::enter && e.target && e.state == "tour/visit") {
      out.push_back("visit " + *e.target + round);
    } else if (e.type == EventType::outcome && e.outcome == "outside_hours") {
      out.push_back("outside_hours " + e.target.value_or("?") + round);
    }
  }
  return out;
}

ExecutorOptions scheduled(long long rounds, double pause_s = 60.0) {
  ExecutorOptions o;
  o.schedule.written = true;
  o.schedule.rounds = rounds;
  o.schedule.pause_s = pause_s;
  o.time_of_day_at_zero_s = kTen;
  return o;
}

std::vector<host::TargetTimes> no_times(std::size_t n) {
  return std::vector<host::TargetTimes>(n);
}

const ExecutorEvent& round_event(const Recorder& r, int round, const std::string& outcome) {
  for (const ExecutorEvent& e : r.events) {
    if (e.type == EventType::round && e.round == round && e.outcome == outcome) return e;
  }
  throw std::runtime_error("no round event " + std::to_string(round) + " " + outcome);
}

TEST(Rounds, RepeatTheTourWithThePauseBetween) {
  Harness h({"rabbit", "pillar"});
  h.load_default();
  h.build(scheduled(3, 60.0));
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(tour_lines(h.recorder),
                          {"round 1 begin", "visit rabbit r1", "visit pillar r1", "round 1 end",
                           "round 2 begin", "visit rabbit r2", "visit pillar r2", "round 2 end",
                           "round 3 begin", "visit rabbit r3", "visit pillar r3", "round 3 end"}));
  // The robot waited where the round ended: nothing entered between a round's end and the next
  // round's begin, and the next began pause_s later.
  for (int round = 1; round < 3; ++round) {
    const double ended = round_event(h.recorder, round, "end").t_s;
    EXPECT_NEAR(round_event(h.recorder, round + 1, "begin").t_s - ended, 60.0, 1e-6);
  }
  EXPECT_EQ(round_event(h.recorder, 3, "end").message.substr(0, 9), "at 10:02:");
  EXPECT_NE(round_event(h.recorder, 3, "end").message.find("the last of 3 rounds"),
            std::string::npos);
  std::vector<std::pair<int, std::string>> done;
  for (const auto& r : h.executor->records()) done.emplace_back(r.round, r.id);
  EXPECT_EQ(done, (std::vector<std::pair<int, std::string>>{{1, "rabbit"},
                                                            {1, "pillar"},
                                                            {2, "rabbit"},
                                                            {2, "pillar"},
                                                            {3, "rabbit"},
                                                            {3, "pillar"}}));
  // Every event of the tour carries its round.
  for (const ExecutorEvent& e : h.recorder.events) EXPECT_GE(e.round, 1) << describe(e);
}

TEST(Rounds, UntilEndsTheToursRoundsAtTheTimeOfDay) {
  Harness h({"rabbit"});
  h.load_default();
  ExecutorOptions o = scheduled(0, 600.0);
  o.schedule.rounds.reset();
  o.schedule.until_s = static_cast<int>(kTen) + 25 * 60;  // 10:25: rounds at 10:00, 10:10, 10:20
  h.build(o);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(
      tour_lines(h.recorder),
      {"round 1 begin", "visit rabbit r1", "round 1 end", "round 2 begin", "visit rabbit r2",
       "round 2 end", "round 3 begin", "visit rabbit r3", "round 3 end"}));
  EXPECT_NE(round_event(h.recorder, 3, "end").message.find(", not before 10:25"), std::string::npos)
      << round_event(h.recorder, 3, "end").message;
}

TEST(Rounds, WithoutAScheduleOnePassUnnumbered) {
  Harness h({"rabbit", "pillar"});
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(tour_lines(h.recorder), {"visit rabbit r0", "visit pillar r0"}));
  for (const auto& r : h.executor->records()) EXPECT_EQ(r.round, 0);
}

TEST(Rounds, TargetOutsideItsHoursIsPassedOverWithTheReason) {
  Harness h({"rabbit", "cafe", "sign"});
  h.load_default();
  ExecutorOptions o = scheduled(2, 3600.0);
  o.target_times = no_times(3);
  o.target_times[1].hours = {{11 * 3600 + 30 * 60, 14 * 3600}, {16 * 3600, 17 * 3600}};
  o.time_of_day_at_zero_s = 11 * 3600 - 5;  // 10:59:55: round 2 at about 11:59:56
  h.build(o);
  EXPECT_EQ(h.run(), TourOutcome::completed);  // passed over is the schedule, not a skip
  ASSERT_TRUE(sequence_is(
      tour_lines(h.recorder),
      {"round 1 begin", "visit rabbit r1", "outside_hours cafe r1", "visit sign r1", "round 1 end",
       "round 2 begin", "visit rabbit r2", "visit cafe r2", "visit sign r2", "round 2 end"}));
  const TargetRecord& passed = h.executor->records()[1];
  EXPECT_EQ(passed.id, "cafe");
  EXPECT_EQ(passed.outcome, "outside_hours");
  EXPECT_EQ(passed.round, 1);
  EXPECT_EQ(passed.reason.rfind("outside its hours (11:30-14:00, 16:00-17:00) at 10:59:5", 0), 0u)
      << passed.reason;
  EXPECT_EQ(h.recorder.done[1].outcome, "outside_hours");  // the checkpoint hook sees it too
  EXPECT_NE(round_event(h.recorder, 1, "end").message.find("1 outside_hours, 2 projected"),
            std::string::npos);
}

// A round that found every target closed waits for the first window to open, not pause_s (a
// pause of 0 would otherwise turn round after round, a tick each).
TEST(Rounds, EveryTargetClosedWaitsForTheNextWindow) {
  Harness h({"cafe"});
  h.load_default();
  ExecutorOptions o = scheduled(5, 5.0);
  o.target_times = no_times(1);
  o.target_times[0].hours = {{static_cast<int>(kTen) + 120, static_cast<int>(kTen) + 122}};
  h.build(o);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(
      tour_lines(h.recorder),
      {"round 1 begin", "outside_hours cafe r1", "round 1 end", "round 2 begin", "visit cafe r2",
       "round 2 end", "round 3 begin", "outside_hours cafe r3", "round 3 end"}));
  EXPECT_NEAR(round_event(h.recorder, 2, "begin").t_s, 120.0, 0.051);
  EXPECT_NE(round_event(h.recorder, 3, "end").message.find("no target's hours open again today"),
            std::string::npos);
}

TEST(Rounds, ContentRotatesPerVisitAndPerRound) {
  Harness h({"menu", "poster"});
  h.load_default();
  ExecutorOptions o = scheduled(4, 1.0);
  o.target_times = no_times(2);
  o.target_times[0].content = {"a.png", "b.mp4", "c.png"};  // per visit
  o.target_times[1].content = {"day.png", "night.png"};
  o.target_times[1].per_round = true;
  h.build(o);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  std::vector<std::string> shown;
  for (const auto& r : h.executor->records()) {
    shown.push_back(r.id + " " + std::to_string(r.round) + " " + r.content + " " +
                    std::to_string(r.content_index));
  }
  EXPECT_EQ(shown,
            (std::vector<std::string>{
                "menu 1 a.png 0", "poster 1 day.png 0", "menu 2 b.mp4 1", "poster 2 night.png 1",
                "menu 3 c.png 2", "poster 3 day.png 0", "menu 4 a.png 0", "poster 4 night.png 1"}));
}

// What a project step is handed as its target's content, visit by visit.
class ContentWitness : public Behaviour {
 public:
  explicit ContentWitness(std::vector<std::string>& seen) : seen_(seen) {}
  void start(Context& ctx) override { seen_.push_back(ctx.target->content.string()); }
  std::optional<Outcome> tick(Context&) override { return Outcome{"succeeded", ""}; }
  void stop(Context&) override {}

 private:
  std::vector<std::string>& seen_;
};

TEST(Rounds, BehavioursSeeTheRotatedContent) {
  Harness h({"menu", "plain"});
  std::vector<std::string> seen;
  h.catalog.add(
      "project", tour_kinds().at("project"), {},
      [&seen](const Params&, const RunContext&) { return std::make_shared<ContentWitness>(seen); });
  h.mission.targets[0].content = "a.png";
  h.mission.targets[1].content = "plain.png";
  h.load_default();
  ExecutorOptions o = scheduled(3, 1.0);
  o.target_times = no_times(2);
  o.target_times[0].content = {"a.png", "b.png"};
  h.build(o);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  EXPECT_EQ(seen, (std::vector<std::string>{"a.png", "plain.png", "b.png", "plain.png", "a.png",
                                            "plain.png"}));
}

// Interrupted in round 2 while projecting on the second target: the checkpoint carries round 2,
// and the resume visits that target and the rest of round 2, then round 3; every target of
// every round is projected exactly once over both runs.
TEST(Rounds, ResumeGoesOnWithTheRoundEachTargetOnce) {
  const test::TempDir scratch;
  const auto file = scratch / "checkpoint.json";
  Checkpoint checkpoint;
  {
    Harness first;
    first.script("project", "succeeded", 5);
    first.load_default();
    first.build(scheduled(3, 30.0));
    bool reached = false;
    while (!reached && first.executor->step()) {
      reached = first.executor->round() == 2 &&
                first.executor->active_state() == "tour/visit/project" &&
                first.executor->current_target() == std::size_t{1};
    }
    ASSERT_TRUE(reached);
    first.executor->request_cancel();
    ASSERT_EQ(first.run(), TourOutcome::interrupted);
    checkpoint.mission = first.mission.name;
    checkpoint.mission_s = first.clock.now_s();
    checkpoint.done = first.executor->records();
    checkpoint.done_against.assign(checkpoint.done.size(), TargetIdentity{});
    checkpoint.current_target = "pillar";
    checkpoint.round = first.executor->round();
    write_file_atomically(file, dump_json(checkpoint_to_json(checkpoint), 2));
  }
  ASSERT_EQ(checkpoint.done.size(), 4u);  // round 1's three, round 2's rabbit
  Harness second;
  const Checkpoint read = read_checkpoint(file, second.mission);
  ASSERT_EQ(read.round, 2);
  second.clock.set(read.mission_s);
  second.load_default();
  second.build(scheduled(3, 30.0));
  second.executor->restore(read.done, std::size_t{1}, *read.round);
  EXPECT_EQ(second.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(
      tour_lines(second.recorder),
      {"round 2 begin", "visit pillar r2", "visit sign r2", "round 2 end", "round 3 begin",
       "visit rabbit r3", "visit pillar r3", "visit sign r3", "round 3 end"}));
  std::map<std::pair<int, std::string>, int> projected;
  for (const auto& r : second.executor->records()) {
    EXPECT_EQ(r.outcome, "projected");
    ++projected[{r.round, r.id}];
  }
  EXPECT_EQ(projected.size(), 9u);
  for (const auto& [key, n] : projected) EXPECT_EQ(n, 1) << key.first << " " << key.second;
}

// Interrupted while waiting for round 2: the resume waits out the pause again and goes on
// with round 2, round 1 not visited again.
TEST(Rounds, ResumeBetweenRoundsStartsTheNextRound) {
  std::vector<TargetRecord> done;
  int round = 0;
  double stopped_s = 0.0;
  {
    Harness first({"rabbit"});
    first.load_default();
    first.build(scheduled(2, 600.0));
    while (first.executor->step() && first.clock.now_s() < 100.0) {
    }
    ASSERT_EQ(first.executor->active_state(), "");  // waiting
    first.executor->request_cancel();
    ASSERT_FALSE(first.executor->step());  // a cancel between rounds ends the tour at once
    ASSERT_EQ(first.executor->outcome(), TourOutcome::interrupted);
    done = first.executor->records();
    round = first.executor->round();
    stopped_s = first.clock.now_s();
  }
  ASSERT_EQ(round, 1);
  Harness second({"rabbit"});
  second.clock.set(stopped_s);
  second.load_default();
  second.build(scheduled(2, 600.0));
  second.executor->restore(done, std::nullopt, round);
  EXPECT_EQ(second.run(), TourOutcome::completed);
  ASSERT_TRUE(sequence_is(
      tour_lines(second.recorder),
      {"round 1 begin", "round 1 end", "round 2 begin", "visit rabbit r2", "round 2 end"}));
}

TEST(RoundsCheckpoint, RoundsAreWrittenAndChecked) {
  Harness h({"rabbit"});
  auto record = [](int round) {
    TargetRecord r;
    r.id = "rabbit";
    r.outcome = "projected";
    r.round = round;
    return r;
  };
  Checkpoint c;
  c.mission = h.mission.name;
  c.round = 2;
  c.done = {record(1), record(2)};
  c.done_against.assign(2, TargetIdentity{});
  const std::string good = dump_json(checkpoint_to_json(c));
  const Checkpoint read = parse_checkpoint(good, "c.json", h.mission);
  EXPECT_EQ(read.round, 2);
  ASSERT_EQ(read.done.size(), 2u);
  EXPECT_EQ(read.done[1].round, 2);

  auto error_of = [&](Checkpoint bad) {
    try {
      parse_checkpoint(dump_json(checkpoint_to_json(bad)), "c.json", h.mission);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  Checkpoint twice = c;
  twice.done = {record(2), record(2)};
  EXPECT_EQ(error_of(twice), "c.json: done[1].id: \"rabbit\" is done already (done[0] in round 2)");
  Checkpoint ahead = c;
  ahead.done = {record(3), record(2)};
  EXPECT_EQ(error_of(ahead),
            "c.json: done[0].round: expected a round from 1 to the checkpoint's 2, got 3");
  Checkpoint unscheduled = c;
  unscheduled.round.reset();
  unscheduled.done = {record(1)};
  unscheduled.done_against.resize(1);
  EXPECT_EQ(error_of(unscheduled), "c.json: done[0].round: a round in a checkpoint without one");
  Json zero = checkpoint_to_json(c);
  zero["round"] = 0;
  EXPECT_THROW(parse_checkpoint(dump_json(zero), "c.json", h.mission), std::runtime_error);
}

}  // namespace
}  // namespace projtour::testing
