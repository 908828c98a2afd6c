// The tick watchdog in-process, with a tick that hangs until the handler lets it go. Meant for
// ThreadSanitizer (`make test-tsan`): the handler works on the published snapshot and the
// drivers' safe stops while the released tick goes on changing the executor, and the loop waits
// in tick_finished() until the handler is done.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <thread>

#include "executor_harness.hpp"
#include "projtour/machine/watchdog.hpp"

namespace projtour::testing {
namespace {

// The order things happened in, from any thread.
class Timeline {
 public:
  void note(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    lines_.push_back(what);
  }
  std::vector<std::string> lines() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return lines_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> lines_;
};

// Blocks in its first tick of the second target until released; a hung device call, say.
class Hanging : public Behaviour {
 public:
  Hanging(std::shared_future<void> release, Timeline* timeline)
      : release_(std::move(release)), timeline_(timeline) {}
  void start(Context&) override { ++runs_; }
  std::optional<Outcome> tick(Context&) override {
    if (runs_ == 2) {
      release_.wait();
      timeline_->note("tick returned");
    }
    return Outcome{"succeeded", ""};
  }

 private:
  std::shared_future<void> release_;
  Timeline* timeline_;
  int runs_ = 0;
};

// A base whose state update() and safe_stop() both touch, under its lock as the Driver
// contract asks (safe_stop may come from the watchdog's thread during a tick).
class LockedBase : public BaseDriver {
 public:
  void update(double t_s) override {
    std::lock_guard<std::mutex> lock(mutex_);
    odometry_.t_s = t_s;
  }
  void safe_stop() override {
    std::lock_guard<std::mutex> lock(mutex_);
    odometry_.v_mps = odometry_.w_radps = 0.0;
    ++safe_stops_;
  }
  void command_velocity(double v_mps, double w_radps) override {
    std::lock_guard<std::mutex> lock(mutex_);
    odometry_.v_mps = v_mps;
    odometry_.w_radps = w_radps;
  }
  Odometry odometry() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return odometry_;
  }
  int safe_stops() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return safe_stops_;
  }

 private:
  mutable std::mutex mutex_;
  Odometry odometry_;
  int safe_stops_ = 0;
};

constexpr const char* kWorkMachine = R"(initial: visit
states:
  visit:
    for_each: target
    initial: work
    states:
      work:
        behaviour: hanging
        on: {succeeded: finish, failed: abort}
    on: {done: finish}
)";

// Regression (issue 12, "the watchdog handler ... reads executor.records() while the main
// thread may still mutate them"): the second target's tick hangs past the limit; the handler
// sees the state and the one record of the snapshot and safe-stops the base while the tick is
// still stuck; it then lets the tick go and is still running when the tick returns, which
// records the second visit in the executor meanwhile; the loop comes out of tick_finished()
// only after the handler, told the tour is over.
TEST(Watchdog, HungTickIsCaughtOnASnapshotAndTheLateTickWaitsForTheHandler) {
  Harness h({"rabbit", "pillar"});
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  Timeline timeline;
  h.catalog.add("hanging", {"succeeded"}, {}, [&](const Params&, const RunContext&) {
    return std::make_shared<Hanging>(released, &timeline);
  });
  auto base = std::make_shared<LockedBase>();
  DriverSet drivers;
  drivers.base = base;
  h.run_context.drivers = &drivers;
  h.load(kWorkMachine);
  h.build();

  TourSnapshot seen;
  std::string seen_state;
  TickWatchdog watchdog([&](const std::string& state, double, const TourSnapshot& last) {
    seen_state = state;
    seen = last;
    for (const auto& d : drivers.all()) d->safe_stop();
    timeline.note("handler: " + state + ", " + std::to_string(last.records->size()) +
                  " record(s), " + std::to_string(base->safe_stops()) + " safe stop(s)");
    release.set_value();
    // The report is being written while the released tick returns and goes on.
    while (timeline.lines().size() < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    timeline.note("handler done");
  });

  Executor& executor = *h.executor;
  auto snapshot = [&] {
    TourSnapshot s;
    s.mission_s = h.clock.now_s();
    s.records = std::make_shared<const std::vector<TargetRecord>>(executor.records());
    s.current_target = executor.current_target();
    s.ignored_cancel = executor.ignored_cancel();
    return s;
  };
  executor.start();
  watchdog.publish(snapshot());
  bool stopped_by_watchdog = false;
  while (!executor.finished()) {
    watchdog.tick_started(executor.active_state(), 0.5);
    executor.step();
    if (!watchdog.tick_finished()) {
      timeline.note("loop: tour over");
      stopped_by_watchdog = true;
      break;
    }
    watchdog.publish(snapshot());
  }

  ASSERT_TRUE(stopped_by_watchdog);
  EXPECT_TRUE(watchdog.fired());
  EXPECT_EQ(timeline.lines(),
            (std::vector<std::string>{"handler: tour/visit/work, 1 record(s), 1 safe stop(s)",
                                      "tick returned", "handler done", "loop: tour over"}));
  EXPECT_EQ(seen_state, "tour/visit/work");
  ASSERT_EQ(seen.records->size(), 1u);
  EXPECT_EQ(seen.records->at(0).id, "rabbit");
  EXPECT_EQ(seen.current_target, std::optional<std::size_t>(1));
  // The released tick finished the second visit in the executor, not in the snapshot.
  EXPECT_EQ(executor.records().size(), 2u);
}

// A tick that ends in time never fires the watchdog, however long the tour.
TEST(Watchdog, TicksWithinTheLimitNeverFire) {
  std::atomic<int> fired{0};
  TickWatchdog watchdog([&](const std::string&, double, const TourSnapshot&) { ++fired; });
  for (int i = 0; i < 1000; ++i) {
    watchdog.publish(TourSnapshot{});
    watchdog.tick_started("tour/visit/work", 5.0);
    EXPECT_TRUE(watchdog.tick_finished());
  }
  EXPECT_FALSE(watchdog.fired());
  EXPECT_EQ(fired.load(), 0);
}

}  // namespace
}  // namespace projtour::testing
