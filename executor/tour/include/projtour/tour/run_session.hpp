#pragma once
// `projtour run` as an object: the command's steps, each a method, over the state they share.
//
//   open   the signals, the mission checked (prepare_run), the run directory claimed, the
//          checkpoint read on --resume and the seed chosen;
//   wire   the run's context, the monitor, drivers, services and behaviours (all made before
//          anything moves), the executor restored from the checkpoint, the events file, the
//          progress, the checkpoint's hook, the history, the ROS 2 status and the watchdog;
//   loop   ticks until the tour ends: the signals and the operator's requests between ticks,
//          the watchdog around each, the pacing by --speed;
//   close  the report, the last checkpoint, the history's row, tour.png and the summary page.
//
// Each of open, wire and loop returns the exit status to end with, or nothing to go on; close
// returns the run's. The in-process integration tests open and wire a session, then step its
// executor themselves to stop at chosen states.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/machine/executor.hpp"
#include "projtour/machine/watchdog.hpp"
#include "projtour/record/checkpoint.hpp"
#include "projtour/record/events.hpp"
#include "projtour/run/report.hpp"
#include "projtour/run/run_directory.hpp"
#include "projtour/tour/runner.hpp"
#include "projtour/views/progress.hpp"

namespace projtour {

class HistoryRecorder;
class MonitorServer;
class MonitorPublisher;
class Ros2Status;
class SignalScope;
class TargetDoneHook;
class TourTrace;
class VisitToTruth;

class RunSession {
 public:
  // Given each driver as it is made, with its interface; returns the driver the run uses (the
  // tests wrap the projector and pan-tilt to record their calls).
  using DriverWrap =
      std::function<std::shared_ptr<Driver>(const std::string& interface, std::shared_ptr<Driver>)>;

  // `out` and `err` must outlive the session.
  RunSession(RunOptions options, std::ostream& out, std::ostream& err);
  ~RunSession();
  RunSession(const RunSession&) = delete;
  RunSession& operator=(const RunSession&) = delete;

  std::optional<int> open();
  // Before wire: each driver goes through `wrap` once made.
  void set_driver_wrap(DriverWrap wrap) { driver_wrap_ = std::move(wrap); }
  std::optional<int> wire();
  std::optional<int> loop();
  int close();

  // After wire.
  Executor& executor() { return *executor_; }
  const RunContext& context() const { return run_; }
  const SteppedClock& clock() const { return clock_; }
  double tick_s() const { return executor_options_.tick_s; }

 private:
  // open's parts: the run directory, the targets' identities and the checkpoint; the seed.
  std::optional<int> claim_run_directory();
  void choose_seed();
  // wire's parts.
  void fill_context();
  std::optional<int> create_instances(std::vector<ServiceInstance>& services,
                                      BehaviourInstances& behaviours);
  void make_executor(std::vector<ServiceInstance> services, BehaviourInstances behaviours);
  std::size_t restore_checkpoint();
  std::optional<int> add_observers(std::size_t already_done);
  // An error before anything moved: said, the drivers made so far safe-stopped, status 2.
  int nothing_moved(const std::string& what);
  // The checkpoint: of the given tour (`round` 0: the latest of the records', for the
  // watchdog's thread, which may not ask the executor), and of the executor's, from the hook.
  void write_checkpoint_of(double mission_s, const std::vector<TargetRecord>& done,
                           std::optional<std::size_t> interrupted_target, int round);
  void write_checkpoint();
  RunSummary summary_of(TourOutcome outcome, double mission_s,
                        const std::vector<TargetRecord>& records,
                        const std::vector<std::string>& ignored_cancel) const;
  TourSnapshot snapshot();
  // The watchdog's handler (on its thread), which ends the process.
  [[noreturn]] void on_hang(const std::string& state, double limit_s, const TourSnapshot& last);
  // loop's parts.
  void take_signals();
  void take_controls();
  void publish();
  void check_writes();
  void pace();
  // close's part: what the run leaves, after the report.
  std::optional<int> write_pictures(const RunSummary& summary);

  // In the order the command made them, so that they are destroyed in the reverse order.
  RunOptions options_;
  std::ostream& out_;
  std::ostream& err_;
  std::chrono::steady_clock::time_point wall_start_;
  std::unique_ptr<SignalScope> signals_;
  std::unique_ptr<PreparedRun> prepared_;
  std::optional<RunDirectory> claimed_;
  std::filesystem::path run_dir_;
  // What each target is done against, read once: every checkpoint records it for the targets
  // done, and a resume visits again those whose pose or model changed since.
  std::vector<TargetIdentity> identities_;
  std::optional<Checkpoint> checkpoint_;
  std::vector<std::string> resume_notes_;
  std::uint64_t seed_ = 1;
  DriverWrap driver_wrap_;

  StderrLogger logger_{LogLevel::warning};
  Blackboard blackboard_;
  SteppedClock clock_;
  DriverSet drivers_;
  RunContext run_;
  std::unique_ptr<MonitorServer> monitor_;
  ExecutorOptions executor_options_;
  std::unique_ptr<Executor> executor_;
  std::optional<JsonlEventWriter> events_;
  std::unique_ptr<ProgressDisplay> progress_;
  // The hung step may return and reach on_target_done while the watchdog's handler writes its
  // checkpoint: whoever comes second must not interleave with (or, for the step, overwrite) the
  // handler's files. Once the handler holds this it never lets go; the process ends.
  std::timed_mutex files_mutex_;
  std::atomic<bool> files_final_{false};
  // A checkpoint that cannot be written (a full disk) ends the tour, after the tick that found
  // it: it is not thrown through the executor, whose step would be left half done.
  std::string write_failure_;
  std::unique_ptr<TargetDoneHook> checkpoint_hook_;
  std::unique_ptr<TourTrace> trace_;
  std::unique_ptr<VisitToTruth> visit_to_truth_;
  std::unique_ptr<HistoryRecorder> history_;
  bool stopping_ = false;  // a stop was asked for: the tour winds down unpaced
  std::unique_ptr<MonitorPublisher> publisher_;
  std::unique_ptr<Ros2Status> ros2_status_;
  // The tour as of the last tick that returned, for the watchdog.
  std::shared_ptr<const std::vector<TargetRecord>> published_records_ =
      std::make_shared<const std::vector<TargetRecord>>();
  std::unique_ptr<TickWatchdog> watchdog_;

  // The loop's pacing.
  double speed_ = 0.0;
  bool cancelled_on_failure_ = false;
  double mission_start_s_ = 0.0;
  std::chrono::steady_clock::time_point pace_start_;
};

}  // namespace projtour
