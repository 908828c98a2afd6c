// Executor overheads: how many state transitions a second the machine follows when every
// behaviour ends at once (the executor's own cost per step of a tour), how long the default
// machine takes to load and check, and how long loading the testing plugin takes.
#include <benchmark/benchmark.h>

#include "projtour/params_reader.hpp"
#include "projtour/plugin_loader.hpp"
#include "projtour_executor/executor.hpp"
#include "projtour_test/run_rig.hpp"
#include "scripted_behaviour.hpp"

namespace projtour {
namespace {

struct Tour {
  InProcessCatalog catalog;
  // No run directory: making target directories is not the executor's cost being measured.
  test::RunRig rig{test::RunRig::RunDir::none};
  MissionSpec& mission = rig.mission;
  SteppedClock& clock = rig.clock;
  RunContext& run = rig.run;

  // The tour's kinds, each playing `scripts[kind]` (default: succeed on the first tick).
  Tour(std::size_t targets, const std::map<std::string, std::string>& scripts) {
    for (std::size_t i = 0; i < targets; ++i) {
      TargetSpec t;
      t.id = "t" + std::to_string(i);
      mission.targets.push_back(t);
    }
    run.dry_run = false;
    const std::map<std::string, std::vector<std::string>> kinds = {
        {"navigate", {"succeeded", "unreachable", "blocked", "timeout", "lost"}},
        {"relocalize", {"succeeded", "lost"}},
        {"aim", {"succeeded", "out_of_reach"}},
        {"capture", {"succeeded", "no_frame"}},
        {"align", {"succeeded", "poor_fit", "no_target"}},
        {"project", {"succeeded", "off_screen"}},
        {"next", {"succeeded", "finished"}}};
    for (const auto& [kind, outcomes] : kinds) {
      Params p = default_params(testing::scripted_param_specs());
      if (scripts.count(kind)) p.set("outcomes", scripts.at(kind));
      catalog.add(kind, outcomes, {}, [p](const Params&, const RunContext& r) {
        return std::make_shared<testing::ScriptedBehaviour>(p, r);
      });
    }
  }
};

void run_tours(benchmark::State& state, const std::map<std::string, std::string>& scripts) {
  const auto targets = static_cast<std::size_t>(state.range(0));
  std::size_t transitions = 0;
  for (auto _ : state) {
    state.PauseTiming();
    Tour tour(targets, scripts);
    Diagnostics diag;
    auto machine = load_machine(MachineSource{}, tour.catalog, diag);
    auto behaviours = create_behaviours(*machine, tour.catalog, tour.run);
    Executor executor(*machine, std::move(behaviours), {}, tour.run, tour.clock);
    state.ResumeTiming();
    executor.run_to_end();
    transitions += executor.transition_count();
  }
  state.counters["transitions_per_s"] =
      benchmark::Counter(static_cast<double>(transitions), benchmark::Counter::kIsRate);
  state.counters["transitions_per_tour"] =
      static_cast<double>(transitions) / static_cast<double>(state.iterations());
}

// Six transitions per target, one tick each.
void BM_HappyTourTransitions(benchmark::State& state) {
  run_tours(state, {});
}
BENCHMARK(BM_HappyTourTransitions)->Arg(10)->Arg(100)->Unit(benchmark::kMicrosecond);

// Retry lists: every target aligns poorly until its retries run out and is skipped.
void BM_RetryHeavyTourTransitions(benchmark::State& state) {
  run_tours(state, {{"align", "poor_fit"}});
}
BENCHMARK(BM_RetryHeavyTourTransitions)->Arg(100)->Unit(benchmark::kMicrosecond);

void BM_LoadDefaultMachine(benchmark::State& state) {
  Tour tour(1, {});
  for (auto _ : state) {
    Diagnostics diag;
    auto machine = load_machine(MachineSource{}, tour.catalog, diag);
    benchmark::DoNotOptimize(machine);
  }
}
BENCHMARK(BM_LoadDefaultMachine)->Unit(benchmark::kMicrosecond);

// dlopen of the testing plugin with the registry's checks, from a fresh registry each time
// (the library is closed again when the registry goes).
void BM_LoadTestingPlugin(benchmark::State& state) {
  const std::string file = std::string(PROJTOUR_PLUGIN_BUILD_DIR) + "/libprojtour_testing.so";
  for (auto _ : state) {
    PluginRegistry registry;
    registry.load_library(file);
    benchmark::DoNotOptimize(registry.find("scripted"));
  }
}
BENCHMARK(BM_LoadTestingPlugin)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
