#include "projtour_executor/runner.hpp"

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <functional>
#include <iostream>
#include <thread>

#include "projtour/blackboard.hpp"
#include "projtour/logger.hpp"
#include "projtour_executor/executor.hpp"
#include "projtour_executor/progress.hpp"
#include "projtour_executor/report.hpp"

namespace projtour {

namespace {

volatile std::sig_atomic_t g_stop_signal = 0;
volatile std::sig_atomic_t g_pause_signal = 0;
volatile std::sig_atomic_t g_resume_signal = 0;

extern "C" void on_stop_signal(int signal) {
  g_stop_signal = signal;
}
extern "C" void on_pause_signal(int) {
  g_pause_signal = 1;
}
extern "C" void on_resume_signal(int) {
  g_resume_signal = 1;
}

// Installs the run's signal handlers and puts the previous ones back when done.
class SignalScope {
 public:
  SignalScope() {
    g_stop_signal = g_pause_signal = g_resume_signal = 0;
    install(SIGINT, on_stop_signal, 0);
    install(SIGTERM, on_stop_signal, 1);
    install(SIGUSR1, on_pause_signal, 2);
    install(SIGUSR2, on_resume_signal, 3);
  }
  ~SignalScope() {
    const int signals[] = {SIGINT, SIGTERM, SIGUSR1, SIGUSR2};
    for (int i = 0; i < 4; ++i) sigaction(signals[i], &previous_[i], nullptr);
  }

 private:
  void install(int signal, void (*handler)(int), int slot) {
    struct sigaction action {};
    action.sa_handler = handler;
    sigemptyset(&action.sa_mask);
    sigaction(signal, &action, &previous_[slot]);
  }
  struct sigaction previous_[4];
};

void print_diagnostics(const Diagnostics& diag, std::ostream& err) {
  for (const auto& d : diag.items()) err << d.format() << "\n";
}

std::filesystem::path default_run_dir(const std::string& mission) {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &local);
  return std::filesystem::path("runs") / (mission + "-" + stamp);
}

std::shared_ptr<Driver> make_driver(const PluginRegistry& registry, const InstanceChoice& c,
                                    const RunContext& run) {
  return registry.create_driver(c.kind, c.params, run);
}

// Fills the DriverSet by interface; the registry has checked each object implements it.
void assign_driver(DriverSet& set, const std::string& interface, std::shared_ptr<Driver> d) {
  if (interface == "base") set.base = std::dynamic_pointer_cast<BaseDriver>(d);
  if (interface == "laser") set.laser = std::dynamic_pointer_cast<LaserDriver>(d);
  if (interface == "pan_tilt") set.pan_tilt = std::dynamic_pointer_cast<PanTiltDriver>(d);
  if (interface == "depth_camera") {
    set.depth_camera = std::dynamic_pointer_cast<DepthCameraDriver>(d);
  }
  if (interface == "projector") set.projector = std::dynamic_pointer_cast<ProjectorDriver>(d);
}

class TargetDoneHook : public ExecutorObserver {
 public:
  explicit TargetDoneHook(std::function<void()> hook) : hook_(std::move(hook)) {}
  void on_target_done(const TargetRecord&) override { hook_(); }

 private:
  std::function<void()> hook_;
};

}  // namespace

int validate_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::everything, diag);
  print_diagnostics(diag, err);
  if (!prepared) {
    err << "projtour: " << diag.error_count() << " problem(s) in " << options.mission.string()
        << "\n";
    return 2;
  }
  out << options.mission.string() << ": ok (" << prepared->mission.targets.size() << " targets, "
      << prepared->machine->leaves().size() << " behaviour states)\n";
  return 0;
}

int graph_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::machine, diag);
  print_diagnostics(diag, err);
  if (!prepared) return 2;
  out << machine_to_dot(*prepared->machine);
  return 0;
}

int run_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  const auto wall_start = std::chrono::steady_clock::now();
  Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::everything, diag);
  print_diagnostics(diag, err);
  if (!prepared) {
    err << "projtour: nothing moved: " << diag.error_count() << " problem(s)\n";
    return 2;
  }
  MissionSpec& mission = prepared->mission;

  if (options.resume && !options.out) {
    err << "projtour: --resume needs --out DIR (the run to continue)\n";
    return 2;
  }
  const std::filesystem::path run_dir = options.out ? *options.out : default_run_dir(mission.name);
  std::optional<Checkpoint> checkpoint;
  if (options.resume) {
    try {
      checkpoint = read_checkpoint(run_dir / "checkpoint.json", mission);
    } catch (const std::exception& e) {
      err << "projtour: cannot resume: " << e.what() << "\n";
      return 2;
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(run_dir / "targets", ec);
  if (ec) {
    err << "projtour: cannot create " << run_dir.string() << ": " << ec.message() << "\n";
    return 2;
  }

  std::uint64_t seed = 1;
  if (prepared->world && prepared->world->seed) seed = *prepared->world->seed;
  if (checkpoint) seed = checkpoint->seed;
  if (options.seed) {
    if (checkpoint && checkpoint->seed != *options.seed) {
      err << "projtour: warning: --seed " << *options.seed << " overrides the checkpoint's seed "
          << checkpoint->seed << "\n";
    }
    seed = *options.seed;
  }

  StderrLogger logger(LogLevel::warning);
  Blackboard blackboard;
  SteppedClock clock;
  if (checkpoint) clock.set(checkpoint->mission_s);
  DriverSet drivers;
  RunContext run;
  run.mission = &mission;
  run.world = prepared->world ? &*prepared->world : nullptr;
  run.dry_run = options.dry_run;
  run.seed = seed;
  run.run_dir = run_dir;
  run.map = prepared->map;
  run.drivers = &drivers;
  run.blackboard = &blackboard;
  run.clock = &clock;
  run.log = &logger;

  // Everything is made before anything moves: a create that throws ends the run here.
  std::vector<ServiceInstance> services;
  BehaviourInstances behaviours;
  try {
    for (const auto& [interface, choice] : prepared->drivers) {
      assign_driver(drivers, interface, make_driver(*prepared->registry, choice, run));
    }
    for (const auto& [role, choice] : prepared->services) {
      services.push_back({role, prepared->registry->create_service(choice.kind, choice.params, run),
                          choice.params});
    }
    behaviours = create_behaviours(*prepared->machine, *prepared->catalog, run);
  } catch (const std::exception& e) {
    err << "projtour: nothing moved: " << e.what() << "\n";
    for (const auto& d : drivers.all()) d->safe_stop();
    return 2;
  }

  ExecutorOptions executor_options;
  executor_options.tick_s = 1.0 / options.tick_hz;
  executor_options.cancel_grace_s = options.cancel_grace_s;
  Executor executor(*prepared->machine, std::move(behaviours), std::move(services), run, clock,
                    executor_options);
  std::size_t already_done = 0;
  if (checkpoint) {
    already_done = checkpoint->done.size();
    std::optional<std::size_t> first;
    for (std::size_t i = 0; i < mission.targets.size(); ++i) {
      if (checkpoint->current_target && mission.targets[i].id == *checkpoint->current_target) {
        first = i;
      }
    }
    executor.restore(checkpoint->done, first);
  }

  JsonlEventWriter events(run_dir / "events.jsonl", options.resume);
  const bool terminal = &out == &std::cout && ::isatty(STDOUT_FILENO) != 0;
  ProgressDisplay progress(out, terminal, mission.targets.size(), already_done);
  auto write_checkpoint = [&] {
    Checkpoint c;
    c.mission = mission.name;
    c.seed = seed;
    c.mission_s = clock.now_s();
    c.done = executor.records();
    if (executor.finished() && executor.outcome() == TourOutcome::interrupted &&
        executor.current_target()) {
      c.current_target = mission.targets[*executor.current_target()].id;
    }
    write_file_atomically(run_dir / "checkpoint.json", checkpoint_to_json(c).dump(2) + "\n");
  };
  TargetDoneHook checkpoint_hook(write_checkpoint);
  executor.add_observer(&events);
  executor.add_observer(&progress);
  executor.add_observer(&checkpoint_hook);

  const double speed = options.speed.value_or(options.dry_run ? 0.0 : 1.0);
  const double mission_start_s = clock.now_s();
  const auto pace_start = std::chrono::steady_clock::now();
  {
    SignalScope signals;
    executor.start();
    while (!executor.finished()) {
      if (g_stop_signal != 0) {
        g_stop_signal = 0;
        err << "\nprojtour: interrupted; cancelling " << executor.active_state() << "\n";
        executor.request_cancel();
      }
      if (g_pause_signal != 0) {
        g_pause_signal = 0;
        executor.pause();
      }
      if (g_resume_signal != 0) {
        g_resume_signal = 0;
        executor.resume();
      }
      executor.step();
      if (speed > 0) {
        const double ahead_s = (clock.now_s() - mission_start_s) / speed;
        std::this_thread::sleep_until(pace_start + std::chrono::duration<double>(ahead_s));
      }
    }
  }
  progress.finish();
  for (const auto& who : executor.ignored_cancel()) {
    err << "projtour: warning: " << who << " ignored the cancel and was stopped\n";
  }
  if (executor.outcome() == TourOutcome::aborted) {
    err << "projtour: aborted: " << executor.abort_reason() << "\n";
  }

  RunSummary summary;
  summary.mission = mission.name;
  summary.dry_run = options.dry_run;
  summary.seed = seed;
  summary.outcome = executor.outcome();
  summary.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  summary.mission_s = clock.now_s();
  summary.targets = executor.records();
  try {
    write_checkpoint();
    write_file_atomically(run_dir / "report.json", build_report(summary).dump(2) + "\n");
  } catch (const std::exception& e) {
    err << "projtour: " << e.what() << "\n";
    return 1;
  }
  print_target_table(summary, out);
  char mission_time[32];
  std::snprintf(mission_time, sizeof mission_time, "%.2f", summary.mission_s);
  out << "tour " << to_string(summary.outcome) << " in " << mission_time
      << " s of mission time; run directory: " << run_dir.string() << "\n";
  return exit_code(summary.outcome);
}

}  // namespace projtour
