// Pauses and cancels through the executor, with scripted behaviours: state time leaves pauses
// out, and a cancelled paused state is stopped as it stands, never resumed or ticked.
#include <gtest/gtest.h>

#include <cmath>

#include "executor_harness.hpp"

namespace projtour::testing {
namespace {

// Notes ctx.state_elapsed_s() at every call, in ticks of 0.05 s.
class Clocked : public Behaviour {
 public:
  explicit Clocked(std::vector<std::string>* log) : log_(log) {}
  void start(Context& ctx) override { note("start", ctx); }
  std::optional<Outcome> tick(Context& ctx) override {
    note("tick", ctx);
    if (++ticks_ < 6) return std::nullopt;
    return Outcome{"succeeded", ""};
  }
  void stop(Context& ctx) override { note("stop", ctx); }
  void pause(Context& ctx) override { note("pause", ctx); }
  void resume(Context& ctx) override { note("resume", ctx); }

 private:
  void note(const char* call, const Context& ctx) {
    log_->push_back(std::string(call) + " " +
                    std::to_string(std::lround(ctx.state_elapsed_s() / 0.05)));
  }
  std::vector<std::string>* log_;
  int ticks_ = 0;
};

constexpr const char* kClockedMachine = R"(initial: visit
states:
  visit:
    for_each: target
    initial: wait
    states:
      wait:
        behaviour: clocked
        on: {succeeded: finish, failed: abort}
    on: {done: finish}
)";

// What a behaviour reads as its own time: 0 at start (the first step enters and ticks), one
// tick per tick, frozen while paused (100 ticks of mission time here) and going on from there
// after the resume.
TEST(PauseCancel, StateElapsedLeavesPausesOut) {
  Harness h({"rabbit"});
  std::vector<std::string> log;
  h.catalog.add("clocked", {"succeeded"}, {}, [&log](const Params&, const RunContext&) {
    return std::make_shared<Clocked>(&log);
  });
  h.load(kClockedMachine);
  h.build();
  for (int i = 0; i < 4; ++i) h.executor->step();
  h.executor->pause();
  for (int i = 0; i < 100; ++i) h.executor->step();
  h.executor->resume();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  EXPECT_EQ(log, (std::vector<std::string>{"start 0", "tick 1", "tick 2", "tick 3", "tick 4",
                                           "pause 4", "resume 4", "tick 5", "tick 6", "stop 6"}));
}

// Regression (issue 12, "cancel while paused calls resume() first"): the paused behaviour is
// stopped without a resume and without another tick, at once (no grace period), and the tour
// is interrupted with the visit unrecorded, as a cancel of a running state would leave it.
TEST(PauseCancel, CancelWhilePausedStopsWithoutResumeOrTick) {
  Harness h;
  h.script("aim", "succeeded", 1000);
  h.load_default();
  h.build();
  ASSERT_TRUE(h.step_until("visit/aim", "rabbit"));
  for (int i = 0; i < 3; ++i) h.executor->step();
  h.executor->pause();
  for (int i = 0; i < 20; ++i) h.executor->step();
  const ScriptedBehaviour& aim = h.behaviour("visit/aim");
  const int ticks_before = aim.ticks_seen();
  const double cancelled_at_s = h.clock.now_s();
  h.executor->request_cancel();
  EXPECT_EQ(h.run(), TourOutcome::interrupted);
  ASSERT_SEQUENCE(h.recorder,
                  seq({{"enter tour", "enter visit @rabbit"},
                       leaf("visit/navigate", "succeeded", "visit/aim", "rabbit"),
                       {"enter visit/aim @rabbit", "outcome visit/aim cancelled @rabbit",
                        "exit visit/aim @rabbit", "exit visit @rabbit", "exit tour"}}));
  EXPECT_EQ(h.recorder.events[h.recorder.events.size() - 4].message, "cancelled while paused");
  EXPECT_EQ(aim.pauses(), 1);
  EXPECT_EQ(aim.resumes(), 0);
  EXPECT_EQ(aim.ticks_seen(), ticks_before);
  EXPECT_EQ(aim.stops(), 1);
  // The very next step, at the paused instant: a pause stands mission time still (issue 16).
  EXPECT_NEAR(h.clock.now_s() - cancelled_at_s, 0.0, 1e-9);
  EXPECT_FALSE(h.executor->paused());
  EXPECT_TRUE(h.executor->records().empty());
  EXPECT_EQ(h.executor->current_target(), std::optional<std::size_t>(0));
  EXPECT_TRUE(h.executor->ignored_cancel().empty());
}

// Issue 16: the operator's skip goes through the leaf's cooperative cancel; the visit ends
// skipped, saying who asked, and the tour goes on to the next target.
TEST(OperatorControl, SkipEndsTheCurrentVisitSkippedAndTheTourGoesOn) {
  Harness h({"rabbit", "sign"});
  h.script("aim", "succeeded", 5);
  h.load_default();
  h.build();
  ASSERT_TRUE(h.step_until("visit/aim", "rabbit"));
  const Executor::ControlReply reply = h.executor->control("skip", "operator");
  EXPECT_TRUE(reply.accepted) << reply.message;
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_SEQUENCE(
      h.recorder,
      seq({{"enter tour", "enter visit @rabbit"},
           leaf("visit/navigate", "succeeded", "visit/aim", "rabbit"),
           {"enter visit/aim @rabbit", "control visit/aim skip by operator @rabbit",
            "outcome visit/aim cancelled @rabbit", "exit visit/aim @rabbit", "exit visit @rabbit"},
           happy_visit("sign"),
           kTourEnd}));
  ASSERT_EQ(h.executor->records().size(), 2u);
  EXPECT_EQ(h.executor->records()[0].outcome, "skipped");
  EXPECT_EQ(h.executor->records()[0].reason, "skipped by operator");
  EXPECT_EQ(h.executor->records()[1].outcome, "projected");
}

// A skip while paused stops the paused leaf as it stands (as a cancel does) and the tour stays
// paused in the next visit, its mission time still, until the operator resumes it.
TEST(OperatorControl, SkipWhilePausedKeepsTheTourPaused) {
  Harness h({"rabbit", "sign"});
  h.script("aim", "succeeded", 1000);
  h.load_default();
  h.build();
  ASSERT_TRUE(h.step_until("visit/aim", "rabbit"));
  EXPECT_TRUE(h.executor->control("pause", "operator").accepted);
  EXPECT_TRUE(h.executor->control("skip", "operator").accepted);
  const double paused_at_s = h.clock.now_s();
  for (int i = 0; i < 50; ++i) h.executor->step();
  EXPECT_TRUE(h.executor->paused());
  EXPECT_EQ(h.executor->current_target(), std::optional<std::size_t>(1));
  EXPECT_EQ(h.executor->active_state(), "tour/visit/navigate");
  EXPECT_NEAR(h.clock.now_s(), paused_at_s, 1e-9);
  EXPECT_EQ(h.behaviour("visit/aim").resumes(), 0);
  EXPECT_TRUE(h.executor->control("resume", "operator").accepted);
  h.script("aim", "succeeded", 1);
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  EXPECT_EQ(h.executor->records()[0].reason, "skipped by operator");
}

// Retry takes a skipped target back: it is visited again later in the tour, its record
// replaced by the new visit's. What cannot be retried is refused and recorded as refused.
TEST(OperatorControl, RetryVisitsASkippedTargetAgainLaterInTheTour) {
  Harness h({"rabbit", "sign", "pillar"});
  h.load_default();
  h.build();
  ASSERT_TRUE(h.step_until("visit/aim", "rabbit"));
  EXPECT_TRUE(h.executor->control("skip", "operator").accepted);
  ASSERT_TRUE(h.step_until("visit/aim", "sign"));
  EXPECT_FALSE(h.executor->control("retry", "operator", "sign").accepted);    // being visited
  EXPECT_FALSE(h.executor->control("retry", "operator", "pillar").accepted);  // not yet visited
  EXPECT_FALSE(h.executor->control("retry", "operator", "nowhere").accepted);
  EXPECT_TRUE(h.executor->control("retry", "operator", "rabbit").accepted);
  EXPECT_EQ(h.run(), TourOutcome::completed);
  std::vector<std::string> order;
  for (const TargetRecord& r : h.executor->records()) order.push_back(r.id + " " + r.outcome);
  EXPECT_EQ(order,
            (std::vector<std::string>{"sign projected", "rabbit projected", "pillar projected"}));
  std::vector<std::string> controls;
  for (const std::string& line : h.recorder.lines()) {
    if (line.rfind("control", 0) == 0) controls.push_back(line);
  }
  EXPECT_EQ(controls,
            (std::vector<std::string>{"control visit/aim skip by operator @rabbit",
                                      "control visit/aim retry sign by operator refused @sign",
                                      "control visit/aim retry pillar by operator refused @sign",
                                      "control visit/aim retry nowhere by operator refused @sign",
                                      "control visit/aim retry rabbit by operator @sign"}));
  // After the tour, nothing is taken.
  EXPECT_FALSE(h.executor->control("pause", "operator").accepted);
}

}  // namespace
}  // namespace projtour::testing
