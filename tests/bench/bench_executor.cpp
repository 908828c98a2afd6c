// Executor overheads: how many state transitions a second the machine follows when every
// behaviour ends at once (the executor's own cost per step of a tour), how long the default
// machine takes to load and check, how long loading the testing plugin takes, and what the live
// monitor adds to a tick, watched or not.
#include <benchmark/benchmark.h>

#include <atomic>
#include <thread>

#include "monitor_hookup.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/machine/executor.hpp"
#include "projtour/views/monitor.hpp"
#include "projtour_test/run_rig.hpp"
#include "projtour_test/tour_kinds.hpp"
#include "scripted_behaviour.hpp"
// After Eigen (the projtour headers): httplib includes <resolv.h>, whose `_res` macro is a
// parameter name in Eigen's headers.
#include <httplib.h>

namespace projtour {
namespace {

struct Tour {
  InProcessCatalog catalog;
  // No run directory: making target directories is not the executor's cost being measured.
  test::RunRig rig{test::RunRig::RunDir::none};
  MissionSpec& mission = rig.mission;
  SteppedClock& clock = rig.clock;
  RunContext& run = rig.run;

  // The tour's kinds, each playing `scripts[kind]` (default: succeed), each step `ticks` long.
  Tour(std::size_t targets, const std::map<std::string, std::string>& scripts,
       long long ticks = 1) {
    for (std::size_t i = 0; i < targets; ++i) {
      TargetSpec t;
      t.id = "t" + std::to_string(i);
      mission.targets.push_back(t);
    }
    run.dry_run = false;
    // Each kind plays its first outcome (its success) unless `scripts` says otherwise.
    for (const auto& [kind, outcomes] : test::tour_kinds()) {
      Params p = host::default_params(testing::scripted_param_specs());
      p.set("outcomes", scripts.count(kind) ? scripts.at(kind) : outcomes.front());
      p.set("ticks", ticks);
      catalog.add(kind, outcomes, {}, [p](const Params&, const RunContext& r) {
        return std::make_shared<testing::ScriptedBehaviour>(p, r);
      });
    }
  }
};

// The default machine over the tour's kinds; a benchmark error (not a crash) when it does not
// load, as when the machine gains a kind the tour above lacks.
std::optional<Machine> default_machine(benchmark::State& state, const InProcessCatalog& catalog) {
  host::Diagnostics diag;
  std::optional<Machine> machine = load_machine(host::MachineSource{}, catalog, diag);
  if (!machine) {
    state.SkipWithError(diag.items().empty() ? "the default machine did not load"
                                             : diag.items().front().format().c_str());
  }
  return machine;
}

void run_tours(benchmark::State& state, const std::map<std::string, std::string>& scripts) {
  const auto targets = static_cast<std::size_t>(state.range(0));
  std::size_t transitions = 0;
  for (auto _ : state) {
    state.PauseTiming();
    Tour tour(targets, scripts);
    auto machine = default_machine(state, tour.catalog);
    if (!machine) return;
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
    host::Diagnostics diag;
    auto machine = load_machine(host::MachineSource{}, tour.catalog, diag);
    benchmark::DoNotOptimize(machine);
  }
}
BENCHMARK(BM_LoadDefaultMachine)->Unit(benchmark::kMicrosecond);

// dlopen of the testing plugin with the registry's checks, from a fresh registry each time
// (the library is closed again when the registry goes).
void BM_LoadTestingPlugin(benchmark::State& state) {
  const std::string file = std::string(PROJTOUR_PLUGIN_BUILD_DIR) + "/libprojtour_testing.so";
  for (auto _ : state) {
    host::PluginRegistry registry;
    registry.load_library(file);
    benchmark::DoNotOptimize(registry.find("scripted"));
  }
}
BENCHMARK(BM_LoadTestingPlugin)->Unit(benchmark::kMicrosecond);

// One tick of the tour loop as the runner does it with the live monitor (issue 16): the step,
// then the snapshot published and the controls taken. Arg -1: no monitor; 0: a monitor no one
// watches; N: N clients reading /api/stream as a browser does (over loopback, each on a thread
// of its own, the server rendering state for them at 2 Hz). Steps last 20 ticks.
void BM_TickWithMonitor(benchmark::State& state) {
  const int clients = static_cast<int>(state.range(0));
  Tour tour(4000, {}, 20);
  auto machine = default_machine(state, tour.catalog);
  if (!machine) return;
  Executor executor(*machine, create_behaviours(*machine, tour.catalog, tour.run), {}, tour.run,
                    tour.clock);
  std::unique_ptr<MonitorServer> monitor;
  std::optional<MonitorPublisher> publisher;
  std::atomic<bool> stop{false};
  std::atomic<long> streamed_bytes{0};
  std::vector<std::thread> readers;
  if (clients >= 0) {
    MonitorOptions options;
    options.port = 0;
    options.token = "benchmark-token-0123456789";
    MonitorServer::Fixed fixed;
    fixed.mission = "bench";
    fixed.machine = &*machine;
    for (const TargetSpec& t : tour.mission.targets) fixed.targets.push_back({t.id, {}});
    monitor = std::make_unique<MonitorServer>(options, std::move(fixed));
    executor.add_observer(monitor.get());
    publisher.emplace(*monitor, executor, tour.run);
    for (int i = 0; i < clients; ++i) {
      readers.emplace_back([&, port = monitor->port()] {
        httplib::Client client("127.0.0.1", port);
        client.set_read_timeout(5, 0);
        client.Get("/api/stream", [&](const char*, std::size_t n) {
          streamed_bytes += static_cast<long>(n);
          return !stop;
        });
      });
    }
    // The streams are open before the first measured tick.
    while (clients > 0 && streamed_bytes == 0) {
      executor.step();
      publisher->publish();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  for (auto _ : state) {
    if (!executor.step()) {
      state.SkipWithError("the tour ended before the iterations did");
      break;
    }
    if (publisher) {
      publisher->publish();
      monitor->drain_controls([](const MonitorControl&) { return MonitorReply{}; });
    }
  }
  stop = true;
  monitor.reset();  // ends the streams
  for (auto& r : readers) r.join();
  state.counters["streamed_kB"] = static_cast<double>(streamed_bytes) / 1000.0;
}
BENCHMARK(BM_TickWithMonitor)
    ->Arg(-1)
    ->Arg(0)
    ->Arg(1)
    ->Arg(4)
    ->Iterations(200000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
