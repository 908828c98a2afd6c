#pragma once
// Runs a Machine: one leaf state active at a time, ticked at a fixed mission-time step.
// Single-threaded: pause/resume/request_cancel are called between steps (a signal handler only
// sets flags that the runner turns into these calls).
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/machine/catalog.hpp"
#include "projtour/machine/machine.hpp"
#include "projtour/navigation/path_planner.hpp"
#include "projtour/record/events.hpp"

namespace projtour {

enum class TourOutcome { running, completed, completed_with_skips, aborted, interrupted };
const char* to_string(TourOutcome outcome);
// The exit status README.md's "The command" gives: 0, 3, 1, 130.
int exit_code(TourOutcome outcome);

struct ExecutorOptions {
  double tick_s = 0.05;  // 20 Hz
  // Mission time a cancelled behaviour gets to return before it is stopped by force.
  double cancel_grace_s = 2.0;
  // All day (README "All day"): the mission's schedule and each target's hours and content list,
  // by target index (empty: none has either). The defaults are one unnumbered pass.
  host::MissionSchedule schedule;
  std::vector<host::TargetTimes> target_times;
  // Seconds after local midnight at mission time 0; hours and until are read against it.
  double time_of_day_at_zero_s = 0.0;
};

struct ServiceInstance {
  std::string role;
  std::shared_ptr<Service> service;
  Params params;
};

// ExecutorOptions::time_of_day_at_zero_s for a run whose clock reads `mission_now_s` now: in a
// dry run the schedule's start (mission time 0 at start, so a resume goes on from the time of
// day it stopped at), on the robot the wall clock's local time of day.
double time_of_day_at_zero_s(const host::MissionSchedule& schedule, bool dry_run,
                             double mission_now_s);

using BehaviourInstances = std::map<std::string, std::shared_ptr<Behaviour>>;  // by leaf path

// One behaviour per leaf state, all made before anything moves (a create that throws stops the
// run before motion). Throws what the catalog throws, with the state path prepended.
BehaviourInstances create_behaviours(const Machine& machine, const BehaviourCatalog& catalog,
                                     const RunContext& run);

class Executor {
 public:
  // `run` must outlive the executor and point at the mission, blackboard and `clock`.
  Executor(Machine machine, BehaviourInstances behaviours, std::vector<ServiceInstance> services,
           RunContext& run, SteppedClock& clock, ExecutorOptions options = {});
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  void add_observer(ExecutorObserver* observer) { observers_.push_back(observer); }

  // Before start: targets already done (never revisited in `round`, the schedule's round the
  // checkpoint was in) and the target to visit first (an interrupted one), from a checkpoint.
  void restore(std::vector<TargetRecord> done, std::optional<std::size_t> first_target,
               int round = 1);
  // Starts the services and enters the root state (step() does this when not yet started).
  void start();
  // Enters the machine directly at `state_path` (its ancestors entered first), visiting target
  // `target_index` if the state lies in a for_each.
  void start_at(const std::string& state_path, std::size_t target_index);
  // One tick: advance the clock, update drivers and services, tick the active behaviour and
  // follow any outcome. False once the tour has ended.
  bool step();
  // step() until the end; returns the outcome.
  TourOutcome run_to_end();

  void pause();
  void resume();
  bool paused() const { return paused_; }
  // Cooperative: the behaviour sees ctx.cancel_requested() and gets cancel_grace_s to return. A
  // paused behaviour is stopped at the next step without being resumed.
  void request_cancel();

  // An operator's or a signal's request, by name: pause, resume, cancel (the tour), skip (the
  // current visit ends `skipped`, reason "skipped by <by>", through the same cooperative cancel
  // as the tour's: the leaf gets cancel_grace_s to return), retry (`target`, skipped or failed
  // earlier, is visited again later in the tour; its record is replaced by the new visit's).
  // Every request is recorded as a `control` event with who asked, accepted or not.
  struct ControlReply {
    bool accepted = false;
    std::string message;  // why not, or what was done
  };
  ControlReply control(const std::string& request, const std::string& by,
                       const std::string& target = "");
  bool finished() const { return finished_; }
  TourOutcome outcome() const { return outcome_; }
  // Finished targets in the order they were visited (restored ones first).
  const std::vector<TargetRecord>& records() const { return records_; }
  // The target being visited (or interrupted), if any.
  std::optional<std::size_t> current_target() const { return current_target_; }
  // Path of the active leaf, "" when none.
  std::string active_state() const;
  const std::string& abort_reason() const { return abort_reason_; }
  // Leaf paths whose behaviour ignored a cancel and had to be stopped.
  const std::vector<std::string>& ignored_cancel() const { return ignored_cancel_; }
  std::size_t transition_count() const { return transition_count_; }
  std::size_t target_count() const;
  std::size_t done_count() const { return done_.size(); }
  // The schedule's round being visited (or waited for), from 1.
  int round() const { return round_; }
  // Local time of day of mission time `t_s`, seconds after midnight (may pass 86400).
  double time_of_day_s(double t_s) const { return options_.time_of_day_at_zero_s + t_s; }

 private:
  bool start_services();
  // A state to enter or the active leaf's outcome, processed in order by process_requests().
  struct Request {
    const StateSpec* enter = nullptr;
    std::optional<Outcome> leaf_end;
  };
  void request_enter(const StateSpec& state);
  void request_leaf_end(Outcome outcome);
  void process_requests();
  void emit(EventType type, const StateSpec& state, const std::string& outcome = "",
            const std::string& message = "", const std::string& to = "");
  // Stamps the round and hands the event to every observer.
  void publish(ExecutorEvent& event);
  // States and transitions (executor.cpp). enter() enters any state; a for_each starts its
  // visits (visit_next_target), a leaf starts its behaviour (enter_leaf).
  void enter(const StateSpec& state);
  void enter_leaf(const StateSpec& state);
  // The leaf's outcome as the machine reads it (an undeclared one is a failure): stop_leaf, then
  // the transition for it, or the tour's abort when there is none.
  void follow_leaf_outcome(Outcome outcome);
  // Stops the active leaf's behaviour, takes the visit's measurements, exits and pops the leaf;
  // follows nothing (a cancel's callers decide what comes next).
  void stop_leaf(const Outcome& outcome);
  void follow(const StateSpec& from, const TransitionSpec& transition, const std::string& reason);
  // A composite reached its final state: a for_each's visit ends `projected`; any other
  // composite is unwound and exited, then follow_composite_done.
  void exit_composite(const StateSpec& composite);
  // The exited composite's `done` outcome: the root's ends the tour, any other's is followed.
  void follow_composite_done(const StateSpec& composite);
  void unwind_to(const StateSpec* keep);
  void abort_tour(const std::string& reason);
  void interrupt();
  void finish_tour(TourOutcome outcome);

  // Visits and rounds (executor_visits.cpp).
  // Picks the next target not done (passing over those outside their hours) and starts its
  // visit; with none left, ends the round.
  void visit_next_target(const StateSpec& for_each);
  // Starts the visit of target `index`: per-target state reset, its directory, the enter event.
  void start_target_visit(const StateSpec& for_each, std::size_t index);
  std::optional<std::size_t> choose_next_target(const StateSpec& for_each);
  std::size_t nearest_target(const PoseEstimate2D& estimate,
                             const std::vector<std::size_t>& remaining);
  // Records the visit in progress as done with `outcome` and exits its for_each state, without
  // going on (the tour's abort and interrupt end there).
  void record_visit(const std::string& outcome, const std::string& reason);
  // record_visit, then visit_next_target: the visit ended and the tour goes on.
  void record_visit_then_next(const std::string& outcome, const std::string& reason);
  // The visit ends unrecorded and its target goes last (defer_target), or is skipped.
  void defer_visit(const std::string& reason);
  // Exits the visit's states and its for_each, recording nothing.
  void exit_visit_state();
  int retries_taken() const;
  // All day: why target `index` is passed over now ("" when it is within its hours), its record
  // and event; the end of a round (the next after the pause, or the visit loop's end) and the
  // start of the next one once its time has come.
  std::string outside_hours(std::size_t index) const;
  void pass_over(const StateSpec& for_each, std::size_t index, const std::string& reason);
  void end_round(const StateSpec& for_each);
  void start_next_round();
  void emit_round(const StateSpec& for_each, const std::string& outcome,
                  const std::string& message);

  // The operator's controls (executor_controls.cpp).
  // After a leaf ended on a cancel: the operator's skip of the visit, or the tour's end.
  void after_cancelled_leaf();
  ControlReply skip_current(const std::string& by);
  ControlReply retry_target(const std::string& id);
  Context make_context(const StateSpec* leaf) const;

  Machine machine_;
  BehaviourInstances behaviours_;
  std::vector<ServiceInstance> services_;
  std::vector<Context> service_contexts_;
  RunContext& run_;
  SteppedClock& clock_;
  ExecutorOptions options_;
  std::vector<ExecutorObserver*> observers_;

  std::vector<const StateSpec*> active_;  // root ... leaf
  Behaviour* leaf_behaviour_ = nullptr;
  Context leaf_ctx_;
  StateTimer leaf_timer_;  // mission time in the leaf, pauses excluded (ctx.state_elapsed_s())
  CancelToken cancel_;
  bool started_ = false;
  bool paused_ = false;
  bool cancel_requested_ = false;
  double cancel_started_s_ = 0.0;
  std::optional<std::string> skip_reason_;  // a skip of the visit is cancelling its leaf
  bool finished_ = false;
  TourOutcome outcome_ = TourOutcome::running;
  std::string driver_failure_;

  std::optional<std::size_t> current_target_;
  std::optional<std::size_t> first_target_;
  const StateSpec* visit_state_ = nullptr;   // the for_each being visited
  std::map<std::string, int> retries_used_;  // per state path, in the current visit
  TargetRecord record_;
  bool visit_projected_ = false;  // the project behaviour succeeded in this visit
  std::vector<TargetRecord> records_;
  std::set<std::size_t> done_;
  std::set<std::size_t> deferred_;  // visits left for later (defer_target), once each
  std::string abort_reason_;
  std::vector<std::string> ignored_cancel_;
  std::size_t transition_count_ = 0;
  std::deque<Request> requests_;
  int round_ = 1;
  bool round_open_ = false;                      // its begin event was written
  const StateSpec* waiting_for_each_ = nullptr;  // between rounds: the visit loop to go on with
  double next_round_s_ = 0.0;
  std::optional<TargetSpec> visit_target_;  // the target as this visit shows it (content rotated)
  std::uint64_t leaf_entry_writes_ = 0;     // blackboard writes before the leaf started
  std::unique_ptr<navigation::PathPlanner> planner_;  // order: nearest, on the run's map
  double start_s_ = 0.0;
  long long ticks_ = 0;
};

}  // namespace projtour
