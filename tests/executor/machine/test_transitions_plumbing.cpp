// The executor's plumbing around the state machine, in-process with scripted behaviours: the
// bounded transition loop, the blackboard's per-visit keys, the observers and events, mission
// time, and the services and drivers ticked beside the states. The sequences of states
// themselves are test_transitions.cpp's.
#include <gtest/gtest.h>

#include "executor_harness.hpp"
#include "projtour/contract/blackboard_keys.hpp"

namespace projtour::testing {
namespace {

constexpr Key<int> kVisitProbe{"probe", KeyScope::visit, "int"};
constexpr Key<int> kTourProbe{"tour.probe", KeyScope::tour, "int"};
constexpr Key<long long> kUpdates{"tour.updates", KeyScope::tour, "long long"};

// Sees whether a per-target key survived into the next visit, then writes one.
class TargetKeyProbe : public Behaviour {
 public:
  explicit TargetKeyProbe(std::vector<bool>* seen) : seen_(seen) {}
  void start(Context& ctx) override {
    seen_->push_back(ctx.blackboard().has(kVisitProbe));
    ctx.blackboard().set(kVisitProbe, 1);
    ctx.blackboard().set(kTourProbe, 1);
  }
  std::optional<Outcome> tick(Context&) override { return Outcome{"succeeded", ""}; }

 private:
  std::vector<bool>* seen_;
};

class ThrowsOnStart : public Behaviour {
 public:
  void start(Context&) override { throw std::runtime_error("no device"); }
  std::optional<Outcome> tick(Context&) override { return Outcome{"succeeded", ""}; }
};

// States that end as they start never reach a tick: the transitions used to recurse (one stack
// frame chain per transition) up to a guard; they are now queued requests processed in a
// bounded loop, which ends the tour with the reason.
TEST(Transitions, StatesThatEndAtOnceForeverAreABoundedLoopNotARecursion) {
  Harness h;
  h.catalog.add("throws", {"succeeded"}, {},
                [](const Params&, const RunContext&) { return std::make_shared<ThrowsOnStart>(); });
  // The loader refuses this machine (a cycle of plain transitions, issue 15); the executor's
  // bound still holds for a machine built in code.
  auto root = std::make_unique<StateSpec>();
  root->name = root->path = "tour";
  root->type = StateType::composite;
  root->initial = "a";
  for (const std::string name : {"a", "b"}) {
    auto s = std::make_unique<StateSpec>();
    s->name = name;
    s->path = "tour/" + name;
    s->parent = root.get();
    s->behaviour = "throws";
    for (const char* outcome : {"succeeded", "failed"}) {
      TransitionSpec t;
      t.outcome = outcome;
      t.targets = {name == "a" ? "b" : "a"};
      s->on.push_back(t);
    }
    root->children.push_back(std::move(s));
  }
  h.machine = Machine(std::move(root));
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::aborted);
  EXPECT_NE(h.executor->abort_reason().find(
                "more than 1000 transitions without a tick (a loop of states that end at once)"),
            std::string::npos)
      << h.executor->abort_reason();
  EXPECT_EQ(h.executor->transition_count(), 1001u);
}

TEST(Transitions, TargetKeysClearedWhenAVisitStarts) {
  Harness h;
  std::vector<bool> seen;
  h.catalog.add("probe", {"succeeded"}, {}, [&seen](const Params&, const RunContext&) {
    return std::make_shared<TargetKeyProbe>(&seen);
  });
  h.load(R"(initial: visit
states:
  visit:
    for_each: target
    initial: probe
    states:
      probe:
        behaviour: probe
        on: {succeeded: finish, failed: abort}
    on: {done: finish}
)");
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  EXPECT_EQ(seen, (std::vector<bool>{false, false, false}));
  EXPECT_TRUE(h.blackboard.has(kTourProbe));
}

TEST(Transitions, TargetDoneObserverGetsEveryRecord) {
  Harness h;
  h.script("capture", "no_frame,no_frame,no_frame,succeeded");
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed_with_skips);
  ASSERT_EQ(h.recorder.done.size(), 3u);
  EXPECT_EQ(h.recorder.done[0].outcome, "skipped");
  EXPECT_EQ(h.recorder.done[0].reason, "no_frame");
  EXPECT_EQ(h.recorder.done[1].outcome, "projected");
}

TEST(Transitions, ExitCodes) {
  EXPECT_EQ(exit_code(TourOutcome::completed), 0);
  EXPECT_EQ(exit_code(TourOutcome::completed_with_skips), 3);
  EXPECT_EQ(exit_code(TourOutcome::aborted), 1);
  EXPECT_EQ(exit_code(TourOutcome::interrupted), 130);
}

TEST(Transitions, EventsAreWellFormedJson) {
  Harness h({"rabbit"});
  h.script("align", "poor_fit,succeeded");
  h.load_default();
  h.build();
  h.run();
  for (const auto& e : h.recorder.events) {
    const Json j = parse_json(dump_json(Json(e)), "event");
    ASSERT_TRUE(j.at("t").is_number());
    const std::string type = j.at("event").get<std::string>();
    ASSERT_TRUE(type == "enter" || type == "exit" || type == "outcome" || type == "transition");
    ASSERT_TRUE(j.at("state").get<std::string>().rfind("tour", 0) == 0);
    ASSERT_TRUE(j.at("target").is_null() || j.at("target").get<std::string>() == "rabbit");
    if (type == "transition") {
      ASSERT_FALSE(j.at("to").get<std::string>().empty());
    }
    if (type == "outcome" || type == "transition") {
      ASSERT_FALSE(j.at("outcome").get<std::string>().empty());
    }
  }
}

TEST(Transitions, SameScriptSameEvents) {
  auto events = [] {
    Harness h;
    h.script("align", "poor_fit,succeeded,no_target,succeeded", 3);
    h.script("navigate", "succeeded", 7);
    h.load_default();
    h.build();
    h.run();
    std::string out;
    for (const auto& e : h.recorder.events) out += dump_json(Json(e)) + "\n";
    return out;
  };
  const std::string first = events();
  EXPECT_EQ(first, events());
  EXPECT_GT(first.size(), 1000u);
}

TEST(Transitions, MissionTimeAdvancesByTheTick) {
  Harness h({"rabbit"});
  h.script("navigate", "succeeded", 20);
  h.load_default();
  ExecutorOptions options;
  options.tick_s = 0.1;
  h.build(options);
  h.run();
  // Navigate ends on its 20th tick; each later leaf on its first.
  EXPECT_DOUBLE_EQ(h.recorder.events[3].t_s, 2.0);
  EXPECT_DOUBLE_EQ(h.recorder.events.back().t_s, 2.0 + 0.1 * 7);
}

// Counts its updates on the blackboard; may refuse to start.
class CountingService : public Service {
 public:
  explicit CountingService(bool fail_start) : fail_start_(fail_start) {}
  void start(Context&) override {
    if (fail_start_) throw std::runtime_error("no laser");
  }
  void update(Context& ctx) override { ctx.blackboard().set(kUpdates, ++updates_); }
  void stop(Context&) override { ++stops; }
  int stops = 0;

 private:
  bool fail_start_;
  long long updates_ = 0;
};

// Records what the service had published when it ticked.
class UpdateProbe : public Behaviour {
 public:
  explicit UpdateProbe(std::vector<long long>* seen) : seen_(seen) {}
  void start(Context&) override {}
  std::optional<Outcome> tick(Context& ctx) override {
    const long long* updates = ctx.blackboard().find(kUpdates);
    seen_->push_back(updates != nullptr ? *updates : -1);
    if (seen_->size() < 3) return std::nullopt;
    return Outcome{"succeeded", ""};
  }

 private:
  std::vector<long long>* seen_;
};

TEST(Transitions, ServicesUpdateEveryTickBeforeTheBehaviour) {
  Harness h({"rabbit"});
  std::vector<long long> seen;
  h.catalog.add("probe", {"succeeded"}, {}, [&seen](const Params&, const RunContext&) {
    return std::make_shared<UpdateProbe>(&seen);
  });
  auto service = std::make_shared<CountingService>(false);
  h.services.push_back({"localization", service, Params{}});
  h.load(R"(initial: probe
states:
  probe:
    behaviour: probe
    on: {succeeded: finish, failed: abort}
)");
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  EXPECT_EQ(seen, (std::vector<long long>{1, 2, 3}));
  EXPECT_EQ(service->stops, 1);
}

TEST(Transitions, ServiceThatCannotStartAbortsBeforeAnyState) {
  Harness h({"rabbit"});
  h.services.push_back({"localization", std::make_shared<CountingService>(true), Params{}});
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::aborted);
  EXPECT_TRUE(h.recorder.events.empty());
  EXPECT_EQ(h.executor->abort_reason(), "service localization failed to start: no laser");
  EXPECT_EQ(h.behaviour("visit/navigate").runs(), 0);
}

// A base that notes the times it was updated with and its safe stops.
class RecordingBase : public BaseDriver {
 public:
  void update(double t_s) override { times.push_back(t_s); }
  void safe_stop() override { ++safe_stops; }
  void command_velocity(double, double) override {}
  Odometry odometry() const override { return {}; }
  std::vector<double> times;
  int safe_stops = 0;
};

TEST(Transitions, DriversGetMissionTimeAndAreSafeStoppedAtTheEnd) {
  Harness h({"rabbit"});
  DriverSet drivers;
  auto base = std::make_shared<RecordingBase>();
  drivers.base = base;
  h.run_context.drivers = &drivers;
  h.script("navigate", "succeeded", 3);
  h.load_default();
  h.build();
  EXPECT_EQ(h.run(), TourOutcome::completed);
  ASSERT_EQ(base->times.size(), 10u);  // 3 navigate ticks + one for each later leaf
  EXPECT_DOUBLE_EQ(base->times.front(), 0.05);
  EXPECT_DOUBLE_EQ(base->times.back(), 0.50);
  EXPECT_EQ(base->safe_stops, 1);
}

}  // namespace
}  // namespace projtour::testing
