#include "projtour_executor/runner.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <functional>
#include <future>
#include <iostream>
#include <mutex>
#include <thread>

#include "history_recorder.hpp"
#include "monitor_hookup.hpp"
#include "projtour/blackboard.hpp"
#include "projtour/blackboard_keys.hpp"
#include "projtour/ground_truth.hpp"
#include "projtour/logger.hpp"
#include "projtour_executor/atomic_file.hpp"
#include "projtour_executor/executor.hpp"
#include "projtour_executor/json_io.hpp"
#include "projtour_executor/progress.hpp"
#include "projtour_executor/report.hpp"
#include "projtour_executor/run_directory.hpp"
#include "projtour_executor/summary_page.hpp"
#include "projtour_executor/tour_picture.hpp"
#include "projtour_executor/watchdog.hpp"
#include "ros2_status.hpp"

namespace projtour {

namespace {

// Atomics, not volatile sig_atomic_t: a signal may be delivered to any thread of the process
// (the watchdog's too), and only a lock-free atomic is both async-signal-safe and ordered
// across threads (ThreadSanitizer reported the volatile flags racing with the tick loop).
std::atomic<int> g_stop_signal{0};
std::atomic<int> g_pause_signal{0};
std::atomic<int> g_resume_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "signal flags must be lock-free atomics");

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

// The pacing sleep, in slices: a signal acts within kSignalSlice of wall time at any --speed
// (a slowed-down dry run sleeps minutes per tick).
constexpr auto kSignalSlice = std::chrono::milliseconds(20);
void paced_sleep_until(std::chrono::steady_clock::time_point until) {
  while (g_stop_signal == 0 && g_pause_signal == 0 && g_resume_signal == 0) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= until) return;
    std::this_thread::sleep_for(
        std::min<std::chrono::steady_clock::duration>(until - now, kSignalSlice));
  }
}

// --speed: positive and finite; below real time only where no real base waits on the ticks.
std::string speed_problem(const RunOptions& options) {
  if (!options.speed) return "";
  const double x = *options.speed;
  if (!std::isfinite(x) || !(x > 0.0)) return "--speed must be a positive, finite number";
  if (x < 1.0 && !options.dry_run) {
    return "--speed below 1 only in a dry run: on hardware a slowed tick loop would hold up the "
           "base's commands and the safe stop";
  }
  return "";
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
  if (interface == "colour_camera") {
    set.colour_camera = std::dynamic_pointer_cast<ColourCameraDriver>(d);
  }
}

// Tells the simulated world which target each visit is for (GroundTruth::set_visited_target).
class VisitToTruth : public ExecutorObserver {
 public:
  explicit VisitToTruth(GroundTruth* truth) : truth_(truth) {}
  void on_event(const ExecutorEvent& event) override {
    if (truth_ == nullptr || event.type != EventType::enter || !event.target) return;
    if (*event.target == visited_) return;
    visited_ = *event.target;
    truth_->set_visited_target(visited_);
  }

 private:
  GroundTruth* truth_;
  std::string visited_;
};

// How long the watchdog waits for the drivers' safe stops before it writes the report and ends
// the process anyway (a safe_stop stuck behind the hung call must not keep the report unwritten).
constexpr std::chrono::seconds kWatchdogSafeStopWait{2};
// How long it waits on the history database's lock to end the run's row there.
constexpr std::chrono::milliseconds kWatchdogHistoryWait{1000};

// Safe-stops every driver from a thread of its own; false when they did not all return within
// `wait`. The thread is left behind then, for the process exit to end.
bool safe_stop_within(const DriverSet& drivers, std::chrono::seconds wait) {
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> stopped = done->get_future();
  std::thread([list = drivers.all(), done] {
    for (const auto& d : list) d->safe_stop();
    done->set_value();
  }).detach();
  return stopped.wait_for(wait) == std::future_status::ready;
}

class TargetDoneHook : public ExecutorObserver {
 public:
  explicit TargetDoneHook(std::function<void()> hook) : hook_(std::move(hook)) {}
  void on_target_done(const TargetRecord&) override { hook_(); }

 private:
  std::function<void()> hook_;
};

// What tour.png shows: the estimated and (dry run) true trajectories, sampled every half second
// of mission time, and the last path planned in each visit. Each visit's part is simplified to
// within a centimetre (a fraction of a pixel) when it ends, so a long day's trace stays small.
class TourTrace : public ExecutorObserver {
 public:
  explicit TourTrace(const RunContext& run) : run_(run) {}

  void sample() {
    const double t_s = run_.clock->now_s();
    if (t_s - last_sample_s_ < kSamplePeriodS) return;
    last_sample_s_ = t_s;
    if (const PoseEstimate2D* estimate = run_.blackboard->find(keys::kLocalization)) {
      estimated_.push_back(estimate->mean);
    }
    if (GroundTruth* truth = run_.drivers->ground_truth()) {
      true_.push_back(pose2d_from_isometry(truth->true_T_map_base()));
      for (const Eigen::Vector2d& p : truth->people_positions()) people_.push_back(p);
    }
    if (const NavigateResult* navigated = run_.blackboard->find(keys::kNavigate)) {
      visit_path_ = navigated->planned_path;
    }
  }
  void on_target_done(const TargetRecord&) override {
    if (!visit_path_.empty()) paths_.push_back(simplify_polyline(visit_path_, kToleranceM));
    visit_path_.clear();
    simplify_tail(estimated_, estimated_simplified_);
    simplify_tail(true_, true_simplified_);
  }

  TourPictureInput picture(const MissionSpec& mission,
                           const std::vector<TargetRecord>& records) const {
    TourPictureInput input;
    input.map = run_.map;
    input.start = mission.start;
    input.title = mission.name;
    for (const auto& target : mission.targets) {
      TourPictureTarget t{target.id, pose2d_from_isometry(target.T_map_model), ""};
      for (const auto& r : records) {
        if (r.id == target.id) t.outcome = r.outcome;
      }
      input.targets.push_back(std::move(t));
    }
    input.planned_paths = paths_;
    if (!visit_path_.empty()) input.planned_paths.push_back(visit_path_);
    input.estimated_trajectory = estimated_;
    input.true_trajectory = true_;
    input.people_samples = people_;
    return input;
  }

 private:
  // The samples since the last visit ended, from the last vertex already kept.
  static void simplify_tail(std::vector<Pose2D>& line, std::size_t& simplified) {
    const std::size_t first = simplified == 0 ? 0 : simplified - 1;
    const std::vector<Pose2D> tail =
        simplify_polyline(std::vector<Pose2D>(line.begin() + first, line.end()), kToleranceM);
    line.erase(line.begin() + first, line.end());
    line.insert(line.end(), tail.begin(), tail.end());
    simplified = line.size();
  }

  static constexpr double kSamplePeriodS = 0.5;
  static constexpr double kToleranceM = 0.01;
  const RunContext& run_;
  std::size_t estimated_simplified_ = 0, true_simplified_ = 0;
  double last_sample_s_ = -1e9;
  std::vector<Pose2D> estimated_;
  std::vector<Pose2D> true_;
  std::vector<Eigen::Vector2d> people_;
  std::vector<Pose2D> visit_path_;
  std::vector<std::vector<Pose2D>> paths_;
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
  out << machine_to_dot(*prepared->machine, prepared->catalog.get());
  return 0;
}

int run_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  const auto wall_start = std::chrono::steady_clock::now();
  // From the first moment to the last: a SIGINT while loading becomes a cancel the tick loop
  // honours at once (checkpoint written, resumable), one while the report is written is noted
  // and the finished tour keeps its outcome.
  SignalScope signals;
  Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::everything, diag);
  print_diagnostics(diag, err);
  if (!prepared) {
    err << "projtour: nothing moved: " << diag.error_count() << " problem(s)\n";
    return 2;
  }
  MissionSpec& mission = prepared->mission;
  if (const std::string problem = speed_problem(options); !problem.empty()) {
    err << "projtour: " << problem << "\n";
    return 2;
  }

  std::optional<RunDirectory> claimed;
  try {
    claimed.emplace(RunDirectory::claim(options.out, options.resume, mission.name));
  } catch (const RunDirectoryError& e) {
    err << "projtour: " << e.what() << "\n";
    return 2;
  }
  const std::filesystem::path run_dir = claimed->path();
  // What each target is done against, read once: every checkpoint records it for the targets
  // done, and a resume visits again those whose pose or model changed since.
  std::vector<TargetIdentity> identities;
  try {
    identities = identify_targets(mission);
  } catch (const std::exception& e) {
    err << "projtour: nothing moved: " << e.what() << "\n";
    return 2;
  }
  std::optional<Checkpoint> checkpoint;
  std::vector<std::string> resume_notes;
  if (options.resume) {
    try {
      checkpoint = read_checkpoint(run_dir / "checkpoint.json", mission);
    } catch (const std::exception& e) {
      err << "projtour: cannot resume: " << e.what() << "\n";
      return 2;
    }
    resume_notes = drop_changed_targets(*checkpoint, identities);
    for (const auto& note : resume_notes) err << "projtour: " << note << "\n";
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

  std::unique_ptr<MonitorServer> monitor;
  try {
    monitor = start_monitor(options, *prepared, run_dir, err);
  } catch (const std::exception& e) {
    err << "projtour: nothing moved: " << e.what() << "\n";
    return 2;
  }

  // Everything is made before anything moves: a create that throws ends the run here.
  std::vector<ServiceInstance> services;
  BehaviourInstances behaviours;
  try {
    for (const auto& [interface, choice] : prepared->drivers) {
      assign_driver(drivers, interface, make_driver(*prepared->registry, choice, run));
    }
    if (monitor) tap_frames(drivers, *monitor);
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
  executor_options.schedule = prepared->mission.schedule;
  executor_options.target_times = prepared->mission.target_times;
  executor_options.time_of_day_at_zero_s =
      time_of_day_at_zero_s(prepared->mission.schedule, options.dry_run, clock.now_s());
  Executor executor(*prepared->machine, std::move(behaviours), std::move(services), run, clock,
                    executor_options);
  std::size_t already_done = 0;
  if (checkpoint) {
    // The progress counts the round being resumed.
    already_done = static_cast<std::size_t>(
        std::count_if(checkpoint->done.begin(), checkpoint->done.end(), [&](const TargetRecord& r) {
          return std::max(r.round, 1) == checkpoint->round.value_or(1);
        }));
    std::optional<std::size_t> first;
    for (std::size_t i = 0; i < mission.targets.size(); ++i) {
      if (checkpoint->current_target && mission.targets[i].id == *checkpoint->current_target) {
        first = i;
      }
    }
    executor.restore(checkpoint->done, first, checkpoint->round.value_or(1));
  }

  std::optional<JsonlEventWriter> opened_events;
  try {
    opened_events.emplace(run_dir / "events.jsonl");
  } catch (const std::exception& e) {
    err << "projtour: nothing moved: " << e.what() << "\n";
    for (const auto& d : drivers.all()) d->safe_stop();
    return 2;
  }
  JsonlEventWriter& events = *opened_events;
  const bool terminal = &out == &std::cout && ::isatty(STDOUT_FILENO) != 0;
  ProgressDisplay progress(out, terminal, mission.targets.size(), already_done);
  // `round` 0: the latest of the records' (the watchdog's thread may not ask the executor).
  auto write_checkpoint_of = [&](double mission_s, const std::vector<TargetRecord>& done,
                                 std::optional<std::size_t> interrupted_target, int round) {
    Checkpoint c;
    c.mission = mission.name;
    c.seed = seed;
    c.mission_s = mission_s;
    if (prepared->mission.schedule.written) {
      for (const auto& r : done) round = std::max(round, r.round);
      c.round = std::max(round, 1);
    }
    c.done = done;
    for (const auto& r : done) c.done_against.push_back(identities[r.index]);
    if (interrupted_target) c.current_target = mission.targets[*interrupted_target].id;
    write_file_atomically(run_dir / "checkpoint.json", dump_json(checkpoint_to_json(c), 2) + "\n");
  };
  // The hung step may return and reach on_target_done while the watchdog's handler writes its
  // checkpoint: whoever comes second must not interleave with (or, for the step, overwrite) the
  // handler's files. Once the handler holds this it never lets go; the process ends.
  std::timed_mutex files_mutex;
  std::atomic<bool> files_final{false};
  // A checkpoint that cannot be written (a full disk) ends the tour, after the tick that found
  // it: it is not thrown through the executor, whose step would be left half done.
  std::string write_failure;
  auto write_checkpoint = [&] {
    std::lock_guard<std::timed_mutex> lock(files_mutex);
    if (files_final) return;
    const bool interrupted = executor.finished() && executor.outcome() == TourOutcome::interrupted;
    try {
      write_checkpoint_of(clock.now_s(), executor.records(),
                          interrupted ? executor.current_target() : std::nullopt, executor.round());
    } catch (const std::exception& e) {
      if (write_failure.empty()) write_failure = e.what();
    }
  };
  TargetDoneHook checkpoint_hook(write_checkpoint);
  TourTrace trace(run);
  VisitToTruth visit_to_truth(run.drivers->ground_truth());
  executor.add_observer(&visit_to_truth);
  executor.add_observer(&trace);
  executor.add_observer(&events);
  executor.add_observer(&progress);
  // Before the checkpoint's hook: a visit the checkpoint holds is in the history, and one killed
  // between the two is visited again on resume and its row replaced.
  const std::unique_ptr<HistoryRecorder> history =
      HistoryRecorder::start(options, mission, run_dir, seed, clock, err);
  if (history) executor.add_observer(history.get());
  executor.add_observer(&checkpoint_hook);
  bool stopping = false;  // a stop was asked for: the tour winds down unpaced
  std::optional<MonitorPublisher> publisher;
  if (monitor) {
    executor.add_observer(monitor.get());
    publisher.emplace(*monitor, executor, run);
  }
  std::optional<Ros2Status> ros2_status;
  std::vector<std::string> driver_kinds;
  for (const auto& [interface, choice] : prepared->drivers) driver_kinds.push_back(choice.kind);
  if (!run.dry_run || options.ros2_bridge ? wants_ros2_status(run, driver_kinds) : false) {
    try {
      ros2_status.emplace(executor, run);
    } catch (const std::exception& e) {
      err << "projtour: nothing moved: ROS 2 status: " << e.what() << "\n";
      for (const auto& d : drivers.all()) d->safe_stop();
      return 2;
    }
  }
  // The operator's requests, taken between ticks as the signals are.
  auto take_controls = [&] {
    if (!monitor) return;
    monitor->drain_controls([&](const MonitorControl& c) {
      const Executor::ControlReply r = executor.control(c.request, "operator", c.target);
      if (c.request == "cancel" && r.accepted) stopping = true;
      return MonitorReply{r.accepted, r.message};
    });
  };

  auto summary_of = [&](TourOutcome outcome, double mission_s,
                        const std::vector<TargetRecord>& records,
                        const std::vector<std::string>& ignored_cancel) {
    RunSummary summary;
    summary.mission = mission.name;
    summary.dry_run = options.dry_run;
    summary.seed = seed;
    summary.outcome = outcome;
    summary.wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    summary.mission_s = mission_s;
    summary.targets = records;
    summary.ignored_cancel = ignored_cancel;
    summary.notes = resume_notes;
    return summary;
  };
  auto make_summary = [&](TourOutcome outcome) {
    RunSummary summary =
        summary_of(outcome, clock.now_s(), executor.records(), executor.ignored_cancel());
    if (outcome == TourOutcome::aborted) summary.reason = executor.abort_reason();
    return summary;
  };
  // The tour as of the last tick that returned, for the watchdog.
  auto published_records = std::make_shared<const std::vector<TargetRecord>>();
  auto snapshot = [&] {
    TourSnapshot s;
    s.mission_s = clock.now_s();
    // Records are only ever appended, so a changed count is a changed list.
    if (published_records->size() != executor.records().size()) {
      published_records = std::make_shared<const std::vector<TargetRecord>>(executor.records());
    }
    s.records = published_records;
    s.current_target = executor.current_target();
    s.ignored_cancel = executor.ignored_cancel();
    return s;
  };
  // Runs on the watchdog's thread while the tick loop is stuck inside a step. It reads only
  // `last` (and what is fixed for the run: mission, machine, run directory, the driver set), and
  // should the stuck step return, the loop waits in tick_finished() until this has ended the
  // process.
  //
  // The safe stop is still done from here, although the stuck step may be inside one of those
  // very drivers: a tour abandoned with the base driving and the projector lit is the worse
  // fault, and the Driver contract asks safe_stop to be callable at any time. It runs on a
  // thread of its own, bounded by kWatchdogSafeStopWait, so that a safe_stop blocked behind the
  // hung call cannot also keep the report from being written; the stderr line says when the
  // stop did not complete, for the operator to cut the power.
  TickWatchdog watchdog([&](const std::string& state, double limit_s, const TourSnapshot& last) {
    const bool stopped = safe_stop_within(drivers, kWatchdogSafeStopWait);
    const StateSpec* spec = prepared->machine->find(state);
    RunSummary summary =
        summary_of(TourOutcome::aborted, last.mission_s, *last.records, last.ignored_cancel);
    char limit[32];
    std::snprintf(limit, sizeof limit, "%.1f", limit_s);
    summary.reason = "behaviour " + (spec != nullptr ? spec->behaviour : std::string("?")) +
                     " in state " + state + " hung: one tick ran past " + limit + " s";
    err << "\nprojtour: aborted: " << summary.reason
        << (stopped
                ? "; safe stop done\n"
                : "; SAFE STOP DID NOT COMPLETE within 2 s: a driver is stuck, cut its power\n");
    if (history) {
      history->finish_after_hang(to_string(TourOutcome::aborted), last.mission_s, summary.notes,
                                 static_cast<int>(kWatchdogHistoryWait.count()));
    }
    // Bounded: a step hung inside its own checkpoint write (a stalled disk) holds the lock, and
    // the report still matters more. Never unlocked: the process ends here.
    if (!files_mutex.try_lock_for(kWatchdogSafeStopWait)) {
      err << "projtour: the hung step holds the checkpoint; writing over it\n";
    }
    files_final = true;
    try {
      write_checkpoint_of(last.mission_s, *last.records, std::nullopt, 0);
      write_file_atomically(run_dir / "report.json", dump_json(build_report(summary), 2) + "\n");
    } catch (const std::exception& e) {
      err << "projtour: " << e.what() << "\n";
    }
    err.flush();
    std::_Exit(1);
  });

  const double speed = options.speed.value_or(options.dry_run ? 0.0 : 1.0);
  bool cancelled_on_failure = false;
  const double mission_start_s = clock.now_s();
  auto pace_start = std::chrono::steady_clock::now();
  {
    if (g_stop_signal != 0) {  // while loading: end before any state is entered
      g_stop_signal = 0;
      err << "projtour: interrupted before the tour started\n";
      executor.request_cancel();
      stopping = true;
    }
    executor.start();
    watchdog.publish(snapshot());
    if (publisher) publisher->publish();
    if (ros2_status) ros2_status->publish();
    while (!executor.finished()) {
      if (g_stop_signal != 0) {
        g_stop_signal = 0;
        err << "\nprojtour: interrupted; cancelling " << executor.active_state() << "\n";
        executor.control("cancel", "signal");
        stopping = true;
      }
      if (g_pause_signal != 0) {
        g_pause_signal = 0;
        executor.control("pause", "signal");
      }
      if (g_resume_signal != 0) {
        g_resume_signal = 0;
        executor.control("resume", "signal");
      }
      take_controls();
      const std::string state = executor.active_state();
      const StateSpec* spec = state.empty() ? nullptr : prepared->machine->find(state);
      watchdog.tick_started(
          state, spec != nullptr && spec->timeout_s > 0 ? spec->timeout_s : options.watchdog_s);
      executor.step();
      // The handler has written the report from the snapshot (and, in this command, ended the
      // process): nothing of this tour may be touched again.
      if (!watchdog.tick_finished()) return 1;
      watchdog.publish(snapshot());
      if (publisher) publisher->publish();
      if (ros2_status) ros2_status->publish();
      trace.sample();
      if (write_failure.empty() && !events.error().empty()) write_failure = events.error();
      // Any writer's, a plugin's that only warned included.
      if (write_failure.empty()) write_failure = claimed->first_write_failure();
      if (!write_failure.empty() && !cancelled_on_failure) {
        cancelled_on_failure = true;
        err << "\nprojtour: " << write_failure << "; ending the run\n";
        executor.request_cancel();
        stopping = true;
      }
      // Winding down is not paced: the behaviours' cancel grace is mission time, and the safe
      // stop must not wait on wall time for it (a slowed dry run would take minutes).
      if (executor.paused() && !stopping) {
        // Mission time stands still while paused: wait a tick of wall time (for a signal or the
        // operator) instead of spinning, and start pacing again from where the pause ended.
        const auto before = std::chrono::steady_clock::now();
        paced_sleep_until(before + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                       std::chrono::duration<double>(executor_options.tick_s)));
        pace_start += std::chrono::steady_clock::now() - before;
      } else if (speed > 0 && !stopping) {
        // Bounded, so that a speed of 1e-300 stays a long sleep, not an overflowed cast.
        constexpr double kMaxAheadS = 1e9;
        const double ahead_s = std::min((clock.now_s() - mission_start_s) / speed, kMaxAheadS);
        paced_sleep_until(pace_start +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(ahead_s)));
      }
    }
  }
  if (monitor) {
    publisher->publish();
    monitor->close();
  }
  progress.finish();
  for (const auto& who : executor.ignored_cancel()) {
    err << "projtour: warning: " << who << " ignored the cancel and was stopped\n";
  }
  if (executor.outcome() == TourOutcome::aborted) {
    err << "projtour: aborted: " << executor.abort_reason() << "\n";
  }

  // A run whose files could not all be written failed, whatever its tour did: it ends aborted
  // with the reason, writing what it still can.
  write_checkpoint();
  if (write_failure.empty()) write_failure = claimed->first_write_failure();
  const TourOutcome outcome = write_failure.empty() ? executor.outcome() : TourOutcome::aborted;
  RunSummary summary = make_summary(outcome);
  if (history) history->finish(to_string(outcome), summary.notes);
  if (!write_failure.empty()) summary.reason = write_failure;
  if (GroundTruth* truth = drivers.ground_truth()) summary.building = truth->building_truth();
  try {
    write_file_atomically(run_dir / "report.json", dump_json(build_report(summary), 2) + "\n");
  } catch (const std::exception& e) {
    err << "projtour: run failed: " << e.what() << "\n";
    return 1;
  }
  if (!write_failure.empty()) {
    err << "projtour: run failed: " << write_failure << "\n";
    return 1;
  }
  // The pictures are for people and the report is written; still, a run directory missing its
  // summary is a failed run (a full disk), said so and not lost.
  try {
    if (run.map) write_tour_picture(trace.picture(mission, summary.targets), run_dir / "tour.png");
    write_summary_page(read_summary_input(run_dir), run_dir);
  } catch (const std::exception& e) {
    err << "projtour: run failed: " << e.what() << "\n";
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
