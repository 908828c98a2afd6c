// Pauses and cancels in a dry run of the integration tour inside the test process: the real
// plugins on the simulated drivers, the executor paused, resumed and cancelled as the command
// does on SIGUSR1, SIGUSR2 and SIGINT, and every projector and pan-tilt call recorded.
#include <gtest/gtest.h>
#include <unistd.h>

#include "dry_run.hpp"
#include "in_process_run.hpp"

namespace projtour::integration {
namespace {

constexpr int kSixtySecondsOfTicks = 1200;  // at the executor's 20 Hz

// A visit that projects; `next` finishes the tour after the last target.
std::vector<std::string> happy_visit(const char* next) {
  return {
      "navigate:succeeded",  "aim:succeeded",   "capture:succeeded", "align:succeeded",
      "calibrate:succeeded", "verify:verified", "project:succeeded", std::string("next:") + next};
}

class InProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    for (char& c : name) {
      if (c == '/') c = '_';
    }
    dir_ = fs::temp_directory_path() / ("projtour_ip_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(dir_);
    run_ = std::make_unique<InProcessRun>(data_dir() / "short_tour.yaml",
                                          data_dir() / "nominal_world.yaml", dir_);
  }
  void TearDown() override {
    run_.reset();
    if (!HasFailure()) fs::remove_all(dir_);
  }

  // Pauses for 60 s of mission time `ticks_in` ticks into `step` of the rabbit's visit; the
  // projector and pan-tilt calls made while paused.
  std::vector<std::string> pause_in(const std::string& step, int ticks_in) {
    EXPECT_TRUE(run_->step_until(step, "rabbit"));
    run_->steps(ticks_in);
    EXPECT_EQ(run_->executor().active_state(), "tour/visit/" + step) << "left the step too soon";
    const std::size_t before = run_->device_calls().size();
    run_->paused_for(kSixtySecondsOfTicks);
    const std::vector<std::string> during = run_->device_calls_from(before);
    run_->executor().resume();
    return during;
  }

  fs::path dir_;
  std::unique_ptr<InProcessRun> run_;
};

struct PauseCase {
  const char* step;
  int ticks_in;
  std::vector<std::string> calls_while_paused;
};
void PrintTo(const PauseCase& c, std::ostream* os) {
  *os << c.step << " +" << c.ticks_in << " ticks";
}

class SixtySecondPause : public InProcessTest, public ::testing::WithParamInterface<PauseCase> {};

// A minute's pause in the middle of any step is no fault: the visit goes on to project, the
// tour completes, and while paused the projector and head get nothing but what pausing asks
// (aim holds the head where it is; calibrate, verify and project blank).
TEST_P(SixtySecondPause, VisitStillProjects) {
  const PauseCase& c = GetParam();
  EXPECT_EQ(pause_in(c.step, c.ticks_in), c.calls_while_paused);
  EXPECT_EQ(run_->run_to_end(), TourOutcome::completed);
  EXPECT_EQ(run_->outcomes("rabbit"), happy_visit("succeeded"));
  EXPECT_EQ(run_->outcomes("open-day-sign"), happy_visit("succeeded"));
  ASSERT_EQ(run_->executor().records().size(), 2u);
  for (const auto& r : run_->executor().records()) EXPECT_EQ(r.outcome, "projected") << r.id;
}

INSTANTIATE_TEST_SUITE_P(PauseInEveryStep, SixtySecondPause,
                         ::testing::Values(PauseCase{"navigate", 100, {}},
                                           PauseCase{"aim", 2, {"pan_tilt command"}},
                                           PauseCase{"capture", 0, {}}, PauseCase{"align", 0, {}},
                                           PauseCase{"calibrate", 10, {"projector blank"}},
                                           PauseCase{"verify", 1, {"projector blank"}},
                                           PauseCase{"project", 20, {"projector blank"}}),
                         [](const auto& info) { return std::string(info.param.step); });

// Regression (issue 12, "a pause longer than blocked_s makes navigate return blocked on its
// first tick after resume"): navigate's no-progress limit is 15 s; four times that paused
// while driving, and navigate still arrives, without a blocked, a retry or a replan by timeout.
TEST_F(InProcessTest, PauseLongerThanBlockedSIsNotBlocked) {
  pause_in("navigate", 100);
  run_->steps(1);
  EXPECT_EQ(run_->executor().active_state(), "tour/visit/navigate");
  EXPECT_EQ(run_->run_to_end(), TourOutcome::completed);
  EXPECT_EQ(run_->outcomes("rabbit"), happy_visit("succeeded"));
}

// Pause then cancel while the head is turning: after the pause's hold, the head is never
// commanded again (no resume re-commands its goal) and the projector only blanked.
TEST_F(InProcessTest, PauseThenCancelInAimMovesNothingAfterThePause) {
  ASSERT_TRUE(run_->step_until("aim", "rabbit"));
  run_->steps(2);
  run_->executor().pause();
  const std::size_t after_pause = run_->device_calls().size();
  run_->steps(100);
  run_->executor().request_cancel();
  EXPECT_EQ(run_->run_to_end(), TourOutcome::interrupted);
  EXPECT_EQ(run_->outcomes("rabbit"),
            (std::vector<std::string>{"navigate:succeeded", "aim:cancelled"}));
  EXPECT_EQ(
      run_->device_calls_from(after_pause),
      (std::vector<std::string>{"projector blank", "pan_tilt safe_stop", "projector safe_stop"}));
}

// Pause then cancel while the content is shown: blanked by the pause, never shown again (no
// resume re-shows the last frame), and blank at the end.
TEST_F(InProcessTest, PauseThenCancelInProjectLightsNothingAfterThePause) {
  ASSERT_TRUE(run_->step_until("project", "rabbit"));
  run_->steps(10);
  run_->executor().pause();
  const std::size_t after_pause = run_->device_calls().size();
  ASSERT_GE(after_pause, 1u);
  EXPECT_EQ(run_->device_calls().back().call, "projector blank");
  run_->steps(100);
  run_->executor().request_cancel();
  EXPECT_EQ(run_->run_to_end(), TourOutcome::interrupted);
  EXPECT_EQ(run_->outcomes("rabbit"),
            (std::vector<std::string>{"navigate:succeeded", "aim:succeeded", "capture:succeeded",
                                      "align:succeeded", "calibrate:succeeded", "verify:verified",
                                      "project:cancelled"}));
  EXPECT_EQ(run_->device_calls_from(after_pause),
            (std::vector<std::string>{"projector blank", "projector blank", "pan_tilt safe_stop",
                                      "projector safe_stop"}));
  EXPECT_TRUE(run_->executor().records().empty()) << "an interrupted projection is not recorded";
}

}  // namespace
}  // namespace projtour::integration
