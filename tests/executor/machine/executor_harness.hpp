#pragma once
// In-process executor tests: scripted behaviours under the tour's kind names, a recording
// observer and a whole-sequence assertion.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "projtour/machine/executor.hpp"
#include "projtour_test/run_rig.hpp"
#include "projtour_test/tour_kinds.hpp"
#include "scripted_behaviour.hpp"

namespace projtour::testing {

// "enter visit/navigate @rabbit", "outcome visit/align poor_fit @rabbit",
// "transition visit/align poor_fit -> visit/capture @rabbit" (paths without the root).
std::string describe(const ExecutorEvent& event);

class Recorder : public ExecutorObserver {
 public:
  void on_event(const ExecutorEvent& event) override { events.push_back(event); }
  void on_target_done(const TargetRecord& record) override { done.push_back(record); }
  std::vector<std::string> lines() const;

  std::vector<ExecutorEvent> events;
  std::vector<TargetRecord> done;
};

// Asserts the whole sequence, reporting the first difference with some context.
::testing::AssertionResult sequence_is(const std::vector<std::string>& actual,
                                       const std::vector<std::string>& expected);
#define ASSERT_SEQUENCE(recorder, ...) \
  ASSERT_TRUE(::projtour::testing::sequence_is((recorder).lines(), __VA_ARGS__))

// The events of one leaf that ends with `outcome` and moves on to `to` (a path without the
// root, or skip_target / finish / abort).
std::vector<std::string> leaf(const std::string& path, const std::string& outcome,
                              const std::string& to, const std::string& target);
// Concatenation.
std::vector<std::string> seq(std::initializer_list<std::vector<std::string>> parts);
// One happy visit of the default machine: navigate .. next, then the visit's exit.
std::vector<std::string> happy_visit(const std::string& target);
// The default machine's end once every target is done.
inline const std::vector<std::string> kTourEnd = {
    "outcome visit done", "transition visit done -> done", "enter done", "exit done", "exit tour",
    "outcome tour done"};

class Harness {
 public:
  explicit Harness(std::vector<std::string> target_ids = {"rabbit", "pillar", "sign"});

  // Scripts every behaviour of `kind` (a tour kind such as "align"): outcomes, ticks, ...
  void script(const std::string& kind, const std::string& outcomes, long long ticks = 1,
              long long throw_on = 0, bool ignore_cancel = false);
  // nullopt and the diagnostics when the machine is invalid.
  std::optional<Machine> parse(const std::string& yaml, host::Diagnostics& diag) const;
  void load_default();
  void load(const std::string& yaml);  // fails the test when invalid
  void build(ExecutorOptions options = {});

  TourOutcome run() { return executor->run_to_end(); }
  // Steps until the active leaf is `path` (without the root) for target `target`.
  bool step_until(const std::string& path, const std::string& target, int max_ticks = 100000);
  ScriptedBehaviour& behaviour(const std::string& path);  // path without the root

  InProcessCatalog catalog;
  test::RunRig rig{test::RunRig::RunDir::none};
  MissionSpec& mission = rig.mission;
  Blackboard& blackboard = rig.blackboard;
  SteppedClock& clock = rig.clock;
  RunContext& run_context = rig.run;
  std::optional<Machine> machine;
  std::unique_ptr<Executor> executor;
  Recorder recorder;
  std::vector<ServiceInstance> services;  // handed to the executor by build()

 private:
  std::map<std::string, Params> scripts_;
  BehaviourInstances behaviours_;
};

// The tour's kinds with their outcome sets.
using test::tour_kinds;

}  // namespace projtour::testing
