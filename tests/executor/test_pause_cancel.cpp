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
  EXPECT_NEAR(h.clock.now_s() - cancelled_at_s, 0.05, 1e-9);  // the very next step
  EXPECT_FALSE(h.executor->paused());
  EXPECT_TRUE(h.executor->records().empty());
  EXPECT_EQ(h.executor->current_target(), std::optional<std::size_t>(0));
  EXPECT_TRUE(h.executor->ignored_cancel().empty());
}

}  // namespace
}  // namespace projtour::testing
