#pragma once
// What RunSession (run_session.hpp) builds its run from, apart so that the session's own file
// reads as its steps: the signals, the pacing sleep, the drivers' assignment and safe stop, and
// the observers the command adds to the executor (the world's visited target, the checkpoint's
// hook, the trace tour.png is drawn from).
#include <chrono>
#include <csignal>
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour/record/events.hpp"
#include "projtour/tour/runner.hpp"
#include "projtour/views/tour_picture.hpp"

namespace projtour {

// Installs the run's signal handlers (SIGINT and SIGTERM stop, SIGUSR1 pauses, SIGUSR2
// resumes), clearing what earlier ones set, and puts the previous handlers back when done.
class SignalScope {
 public:
  SignalScope();
  ~SignalScope();
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  void install(int signal, void (*handler)(int), int slot);
  struct sigaction previous_[4];
};

// Each takes the flag its signal set, clearing it: whether the signal came since the last take.
bool take_stop_signal();
bool take_pause_signal();
bool take_resume_signal();

// Sleeps until `until`, in slices, returning early as soon as any of the signals has come.
void paced_sleep_until(std::chrono::steady_clock::time_point until);

void print_diagnostics(const host::Diagnostics& diag, std::ostream& err);

// Why --speed cannot be used in this run, "" when it can.
std::string speed_problem(const RunOptions& options);

// Fills the DriverSet by interface; the registry has checked each object implements it.
void assign_driver(DriverSet& set, const std::string& interface, std::shared_ptr<Driver> d);

// Safe-stops every driver from a thread of its own; false when they did not all return within
// `wait`. The thread is left behind then, for the process exit to end.
bool safe_stop_within(const DriverSet& drivers, std::chrono::seconds wait);

// Tells the simulated world which target each visit is for (GroundTruth::set_visited_target).
class VisitToTruth : public ExecutorObserver {
 public:
  explicit VisitToTruth(GroundTruth* truth) : truth_(truth) {}
  void on_event(const ExecutorEvent& event) override;

 private:
  GroundTruth* truth_;
  std::string visited_;
};

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

  void sample();
  void on_target_done(const TargetRecord&) override;
  TourPictureInput picture(const MissionSpec& mission,
                           const std::vector<TargetRecord>& records) const;

 private:
  // The samples since the last visit ended, from the last vertex already kept.
  static void simplify_tail(std::vector<Pose2D>& line, std::size_t& simplified);

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

}  // namespace projtour
