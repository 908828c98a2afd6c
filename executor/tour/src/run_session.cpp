#include "projtour/tour/run_session.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "history_recorder.hpp"
#include "monitor_hookup.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/run/atomic_file.hpp"
#include "projtour/views/ros2_status.hpp"
#include "projtour/views/summary_page.hpp"
#include "projtour/views/tour_picture.hpp"
#include "run_session_parts.hpp"

namespace projtour {

namespace {

// How long the watchdog waits for the drivers' safe stops before it writes the report and ends
// the process anyway (a safe_stop stuck behind the hung call must not keep the report unwritten).
constexpr std::chrono::seconds kWatchdogSafeStopWait{2};
// How long it waits on the history database's lock to end the run's row there.
constexpr std::chrono::milliseconds kWatchdogHistoryWait{1000};

}  // namespace

RunSession::RunSession(RunOptions options, std::ostream& out, std::ostream& err)
    : options_(std::move(options)),
      out_(out),
      err_(err),
      wall_start_(std::chrono::steady_clock::now()) {}

RunSession::~RunSession() = default;

std::optional<int> RunSession::open() {
  // From the first moment to the last: a SIGINT while loading becomes a cancel the tick loop
  // honours at once (checkpoint written, resumable), one while the report is written is noted
  // and the finished tour keeps its outcome.
  signals_ = std::make_unique<SignalScope>();
  host::Diagnostics diag;
  prepared_ = prepare_run(options_, PrepareDepth::everything, diag);
  print_diagnostics(diag, err_);
  if (!prepared_) {
    err_ << "projtour: nothing moved: " << diag.error_count() << " problem(s)\n";
    return 2;
  }
  if (const std::string problem = speed_problem(options_); !problem.empty()) {
    err_ << "projtour: " << problem << "\n";
    return 2;
  }
  if (const auto status = claim_run_directory()) return status;
  choose_seed();
  return std::nullopt;
}

std::optional<int> RunSession::claim_run_directory() {
  const MissionSpec& mission = prepared_->mission;
  try {
    claimed_.emplace(RunDirectory::claim(options_.out, options_.resume, mission.name));
  } catch (const RunDirectoryError& e) {
    err_ << "projtour: " << e.what() << "\n";
    return 2;
  }
  run_dir_ = claimed_->path();
  try {
    identities_ = identify_targets(mission);
  } catch (const std::exception& e) {
    err_ << "projtour: nothing moved: " << e.what() << "\n";
    return 2;
  }
  if (options_.resume) {
    try {
      checkpoint_ = read_checkpoint(run_dir_ / "checkpoint.json", mission);
    } catch (const std::exception& e) {
      err_ << "projtour: cannot resume: " << e.what() << "\n";
      return 2;
    }
    resume_notes_ = drop_changed_targets(*checkpoint_, identities_);
    for (const auto& note : resume_notes_) err_ << "projtour: " << note << "\n";
  }
  return std::nullopt;
}

void RunSession::choose_seed() {
  if (prepared_->world && prepared_->world->seed) seed_ = *prepared_->world->seed;
  if (checkpoint_) seed_ = checkpoint_->seed;
  if (options_.seed) {
    if (checkpoint_ && checkpoint_->seed != *options_.seed) {
      err_ << "projtour: warning: --seed " << *options_.seed << " overrides the checkpoint's seed "
           << checkpoint_->seed << "\n";
    }
    seed_ = *options_.seed;
  }
}

std::optional<int> RunSession::wire() {
  fill_context();
  try {
    monitor_ = start_monitor(options_, *prepared_, run_dir_, err_);
  } catch (const std::exception& e) {
    err_ << "projtour: nothing moved: " << e.what() << "\n";
    return 2;
  }
  std::vector<ServiceInstance> services;
  BehaviourInstances behaviours;
  if (const auto status = create_instances(services, behaviours)) return status;
  make_executor(std::move(services), std::move(behaviours));
  return add_observers(restore_checkpoint());
}

void RunSession::fill_context() {
  if (checkpoint_) clock_.set(checkpoint_->mission_s);
  run_.mission = &prepared_->mission;
  run_.world = prepared_->world ? &*prepared_->world : nullptr;
  run_.dry_run = options_.dry_run;
  run_.seed = seed_;
  run_.run_dir = run_dir_;
  run_.map = prepared_->map;
  run_.drivers = &drivers_;
  run_.blackboard = &blackboard_;
  run_.clock = &clock_;
  run_.log = &logger_;
}

// Everything is made before anything moves: a create that throws ends the run here.
std::optional<int> RunSession::create_instances(std::vector<ServiceInstance>& services,
                                                BehaviourInstances& behaviours) {
  const host::PluginRegistry& registry = *prepared_->registry;
  try {
    for (const auto& [interface, choice] : prepared_->drivers) {
      std::shared_ptr<Driver> driver = registry.create_driver(choice.kind, choice.params, run_);
      if (driver_wrap_) driver = driver_wrap_(interface, std::move(driver));
      assign_driver(drivers_, interface, std::move(driver));
    }
    if (monitor_) tap_frames(drivers_, *monitor_);
    for (const auto& [role, choice] : prepared_->services) {
      services.push_back(
          {role, registry.create_service(choice.kind, choice.params, run_), choice.params});
    }
    behaviours = create_behaviours(*prepared_->machine, *prepared_->catalog, run_);
  } catch (const std::exception& e) {
    return nothing_moved(e.what());
  }
  return std::nullopt;
}

int RunSession::nothing_moved(const std::string& what) {
  err_ << "projtour: nothing moved: " << what << "\n";
  for (const auto& d : drivers_.all()) d->safe_stop();
  return 2;
}

void RunSession::make_executor(std::vector<ServiceInstance> services,
                               BehaviourInstances behaviours) {
  const host::LoadedMission& mission = prepared_->mission;
  executor_options_.tick_s = 1.0 / options_.tick_hz;
  executor_options_.cancel_grace_s = options_.cancel_grace_s;
  executor_options_.schedule = mission.schedule;
  executor_options_.target_times = mission.target_times;
  executor_options_.time_of_day_at_zero_s =
      time_of_day_at_zero_s(mission.schedule, options_.dry_run, clock_.now_s());
  executor_ = std::make_unique<Executor>(*prepared_->machine, std::move(behaviours),
                                         std::move(services), run_, clock_, executor_options_);
}

// The targets done before, and the one to visit first; returns how many of them the progress
// counts (the round being resumed).
std::size_t RunSession::restore_checkpoint() {
  if (!checkpoint_) return 0;
  const Checkpoint& c = *checkpoint_;
  const auto already_done = static_cast<std::size_t>(std::count_if(
      c.done.begin(), c.done.end(),
      [&](const TargetRecord& r) { return std::max(r.round, 1) == c.round.value_or(1); }));
  const auto& targets = prepared_->mission.targets;
  std::optional<std::size_t> first;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    if (c.current_target && targets[i].id == *c.current_target) first = i;
  }
  executor_->restore(c.done, first, c.round.value_or(1));
  return already_done;
}

std::optional<int> RunSession::add_observers(std::size_t already_done) {
  try {
    events_.emplace(run_dir_ / "events.jsonl");
  } catch (const std::exception& e) {
    return nothing_moved(e.what());
  }
  const MissionSpec& mission = prepared_->mission;
  const bool terminal = &out_ == &std::cout && ::isatty(STDOUT_FILENO) != 0;
  progress_ =
      std::make_unique<ProgressDisplay>(out_, terminal, mission.targets.size(), already_done);
  checkpoint_hook_ = std::make_unique<TargetDoneHook>([this] { write_checkpoint(); });
  trace_ = std::make_unique<TourTrace>(run_);
  visit_to_truth_ = std::make_unique<VisitToTruth>(run_.drivers->ground_truth());
  executor_->add_observer(visit_to_truth_.get());
  executor_->add_observer(trace_.get());
  executor_->add_observer(&*events_);
  executor_->add_observer(progress_.get());
  // Before the checkpoint's hook: a visit the checkpoint holds is in the history, and one killed
  // between the two is visited again on resume and its row replaced.
  history_ = HistoryRecorder::start(options_, mission, run_dir_, seed_, clock_, err_);
  if (history_) executor_->add_observer(history_.get());
  executor_->add_observer(checkpoint_hook_.get());
  if (monitor_) {
    executor_->add_observer(monitor_.get());
    publisher_ = std::make_unique<MonitorPublisher>(*monitor_, *executor_, run_);
  }
  std::vector<std::string> driver_kinds;
  for (const auto& [interface, choice] : prepared_->drivers) driver_kinds.push_back(choice.kind);
  if (!run_.dry_run || options_.ros2_bridge ? wants_ros2_status(run_, driver_kinds) : false) {
    try {
      ros2_status_ = std::make_unique<Ros2Status>(*executor_, run_);
    } catch (const std::exception& e) {
      return nothing_moved(std::string("ROS 2 status: ") + e.what());
    }
  }
  watchdog_ = std::make_unique<TickWatchdog>(
      [this](const std::string& state, double limit_s, const TourSnapshot& last) {
        on_hang(state, limit_s, last);
      });
  return std::nullopt;
}

void RunSession::write_checkpoint_of(double mission_s, const std::vector<TargetRecord>& done,
                                     std::optional<std::size_t> interrupted_target, int round) {
  const host::LoadedMission& mission = prepared_->mission;
  Checkpoint c;
  c.mission = mission.name;
  c.seed = seed_;
  c.mission_s = mission_s;
  if (mission.schedule.written) {
    for (const auto& r : done) round = std::max(round, r.round);
    c.round = std::max(round, 1);
  }
  c.done = done;
  for (const auto& r : done) c.done_against.push_back(identities_[r.index]);
  if (interrupted_target) c.current_target = mission.targets[*interrupted_target].id;
  write_file_atomically(run_dir_ / "checkpoint.json", dump_json(checkpoint_to_json(c), 2) + "\n");
}

void RunSession::write_checkpoint() {
  std::lock_guard<std::timed_mutex> lock(files_mutex_);
  if (files_final_) return;
  const Executor& executor = *executor_;
  const bool interrupted = executor.finished() && executor.outcome() == TourOutcome::interrupted;
  try {
    write_checkpoint_of(clock_.now_s(), executor.records(),
                        interrupted ? executor.current_target() : std::nullopt, executor.round());
  } catch (const std::exception& e) {
    if (write_failure_.empty()) write_failure_ = e.what();
  }
}

RunSummary RunSession::summary_of(TourOutcome outcome, double mission_s,
                                  const std::vector<TargetRecord>& records,
                                  const std::vector<std::string>& ignored_cancel) const {
  RunSummary summary;
  summary.mission = prepared_->mission.name;
  summary.dry_run = options_.dry_run;
  summary.seed = seed_;
  summary.outcome = outcome;
  summary.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
  summary.mission_s = mission_s;
  summary.targets = records;
  summary.ignored_cancel = ignored_cancel;
  summary.notes = resume_notes_;
  return summary;
}

TourSnapshot RunSession::snapshot() {
  TourSnapshot s;
  s.mission_s = clock_.now_s();
  // Records are only ever appended, so a changed count is a changed list.
  if (published_records_->size() != executor_->records().size()) {
    published_records_ = std::make_shared<const std::vector<TargetRecord>>(executor_->records());
  }
  s.records = published_records_;
  s.current_target = executor_->current_target();
  s.ignored_cancel = executor_->ignored_cancel();
  return s;
}

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
void RunSession::on_hang(const std::string& state, double limit_s, const TourSnapshot& last) {
  const bool stopped = safe_stop_within(drivers_, kWatchdogSafeStopWait);
  const StateSpec* spec = prepared_->machine->find(state);
  RunSummary summary =
      summary_of(TourOutcome::aborted, last.mission_s, *last.records, last.ignored_cancel);
  char limit[32];
  std::snprintf(limit, sizeof limit, "%.1f", limit_s);
  summary.reason = "behaviour " + (spec != nullptr ? spec->behaviour : std::string("?")) +
                   " in state " + state + " hung: one tick ran past " + limit + " s";
  err_ << "\nprojtour: aborted: " << summary.reason
       << (stopped ? "; safe stop done\n"
                   : "; SAFE STOP DID NOT COMPLETE within 2 s: a driver is stuck, cut its power\n");
  if (history_) {
    history_->finish_after_hang(to_string(TourOutcome::aborted), last.mission_s, summary.notes,
                                static_cast<int>(kWatchdogHistoryWait.count()));
  }
  // Bounded: a step hung inside its own checkpoint write (a stalled disk) holds the lock, and
  // the report still matters more. Never unlocked: the process ends here.
  if (!files_mutex_.try_lock_for(kWatchdogSafeStopWait)) {
    err_ << "projtour: the hung step holds the checkpoint; writing over it\n";
  }
  files_final_ = true;
  try {
    write_checkpoint_of(last.mission_s, *last.records, std::nullopt, 0);
    write_file_atomically(run_dir_ / "report.json", dump_json(build_report(summary), 2) + "\n");
  } catch (const std::exception& e) {
    err_ << "projtour: " << e.what() << "\n";
  }
  err_.flush();
  std::_Exit(1);
}

std::optional<int> RunSession::loop() {
  speed_ = options_.speed.value_or(options_.dry_run ? 0.0 : 1.0);
  mission_start_s_ = clock_.now_s();
  pace_start_ = std::chrono::steady_clock::now();
  if (take_stop_signal()) {  // while loading: end before any state is entered
    err_ << "projtour: interrupted before the tour started\n";
    executor_->request_cancel();
    stopping_ = true;
  }
  executor_->start();
  publish();
  while (!executor_->finished()) {
    take_signals();
    take_controls();
    const std::string state = executor_->active_state();
    const StateSpec* spec = state.empty() ? nullptr : prepared_->machine->find(state);
    watchdog_->tick_started(
        state, spec != nullptr && spec->timeout_s > 0 ? spec->timeout_s : options_.watchdog_s);
    executor_->step();
    // The handler has written the report from the snapshot (and, in this command, ended the
    // process): nothing of this tour may be touched again.
    if (!watchdog_->tick_finished()) return 1;
    publish();
    trace_->sample();
    check_writes();
    pace();
  }
  return std::nullopt;
}

void RunSession::take_signals() {
  if (take_stop_signal()) {
    err_ << "\nprojtour: interrupted; cancelling " << executor_->active_state() << "\n";
    executor_->control("cancel", "signal");
    stopping_ = true;
  }
  if (take_pause_signal()) executor_->control("pause", "signal");
  if (take_resume_signal()) executor_->control("resume", "signal");
}

// The operator's requests, taken between ticks as the signals are.
void RunSession::take_controls() {
  if (!monitor_) return;
  monitor_->drain_controls([&](const MonitorControl& c) {
    const Executor::ControlReply r = executor_->control(c.request, "operator", c.target);
    if (c.request == "cancel" && r.accepted) stopping_ = true;
    return MonitorReply{r.accepted, r.message};
  });
}

void RunSession::publish() {
  watchdog_->publish(snapshot());
  if (publisher_) publisher_->publish();
  if (ros2_status_) ros2_status_->publish();
}

void RunSession::check_writes() {
  if (write_failure_.empty() && !events_->error().empty()) write_failure_ = events_->error();
  // Any writer's, a plugin's that only warned included.
  if (write_failure_.empty()) write_failure_ = claimed_->first_write_failure();
  if (!write_failure_.empty() && !cancelled_on_failure_) {
    cancelled_on_failure_ = true;
    err_ << "\nprojtour: " << write_failure_ << "; ending the run\n";
    executor_->request_cancel();
    stopping_ = true;
  }
}

// Winding down is not paced: the behaviours' cancel grace is mission time, and the safe stop
// must not wait on wall time for it (a slowed dry run would take minutes).
void RunSession::pace() {
  using Duration = std::chrono::steady_clock::duration;
  if (executor_->paused() && !stopping_) {
    // Mission time stands still while paused: wait a tick of wall time (for a signal or the
    // operator) instead of spinning, and start pacing again from where the pause ended.
    const auto before = std::chrono::steady_clock::now();
    paced_sleep_until(before + std::chrono::duration_cast<Duration>(
                                   std::chrono::duration<double>(executor_options_.tick_s)));
    pace_start_ += std::chrono::steady_clock::now() - before;
  } else if (speed_ > 0 && !stopping_) {
    // Bounded, so that a speed of 1e-300 stays a long sleep, not an overflowed cast.
    constexpr double kMaxAheadS = 1e9;
    const double ahead_s = std::min((clock_.now_s() - mission_start_s_) / speed_, kMaxAheadS);
    paced_sleep_until(pace_start_ +
                      std::chrono::duration_cast<Duration>(std::chrono::duration<double>(ahead_s)));
  }
}

int RunSession::close() {
  if (monitor_) {
    publisher_->publish();
    monitor_->close();
  }
  progress_->finish();
  for (const auto& who : executor_->ignored_cancel()) {
    err_ << "projtour: warning: " << who << " ignored the cancel and was stopped\n";
  }
  if (executor_->outcome() == TourOutcome::aborted) {
    err_ << "projtour: aborted: " << executor_->abort_reason() << "\n";
  }
  // A run whose files could not all be written failed, whatever its tour did: it ends aborted
  // with the reason, writing what it still can.
  write_checkpoint();
  if (write_failure_.empty()) write_failure_ = claimed_->first_write_failure();
  const TourOutcome outcome = write_failure_.empty() ? executor_->outcome() : TourOutcome::aborted;
  RunSummary summary =
      summary_of(outcome, clock_.now_s(), executor_->records(), executor_->ignored_cancel());
  if (outcome == TourOutcome::aborted) summary.reason = executor_->abort_reason();
  if (history_) history_->finish(to_string(outcome), summary.notes);
  if (!write_failure_.empty()) summary.reason = write_failure_;
  if (GroundTruth* truth = drivers_.ground_truth()) summary.building = truth->building_truth();
  try {
    write_file_atomically(run_dir_ / "report.json", dump_json(build_report(summary), 2) + "\n");
  } catch (const std::exception& e) {
    err_ << "projtour: run failed: " << e.what() << "\n";
    return 1;
  }
  if (!write_failure_.empty()) {
    err_ << "projtour: run failed: " << write_failure_ << "\n";
    return 1;
  }
  if (const auto status = write_pictures(summary)) return *status;
  print_target_table(summary, out_);
  char mission_time[32];
  std::snprintf(mission_time, sizeof mission_time, "%.2f", summary.mission_s);
  out_ << "tour " << to_string(summary.outcome) << " in " << mission_time
       << " s of mission time; run directory: " << run_dir_.string() << "\n";
  return exit_code(summary.outcome);
}

// The pictures are for people and the report is written; still, a run directory missing its
// summary is a failed run (a full disk), said so and not lost.
std::optional<int> RunSession::write_pictures(const RunSummary& summary) {
  try {
    if (run_.map) {
      write_tour_picture(trace_->picture(prepared_->mission, summary.targets),
                         run_dir_ / "tour.png");
    }
    write_summary_page(read_summary_input(run_dir_), run_dir_);
  } catch (const std::exception& e) {
    err_ << "projtour: run failed: " << e.what() << "\n";
    return 1;
  }
  return std::nullopt;
}

}  // namespace projtour
