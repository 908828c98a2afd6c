#include "projtour/machine/executor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/run_files.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/record/measurements.hpp"

namespace projtour {

namespace {
constexpr std::size_t kMaxTransitionsPerTick = 1000;
}  // namespace

const char* to_string(TourOutcome outcome) {
  switch (outcome) {
    case TourOutcome::running:
      return "running";
    case TourOutcome::completed:
      return "completed";
    case TourOutcome::completed_with_skips:
      return "completed_with_skips";
    case TourOutcome::aborted:
      return "aborted";
    case TourOutcome::interrupted:
      return "interrupted";
  }
  return "?";
}

int exit_code(TourOutcome outcome) {
  switch (outcome) {
    case TourOutcome::completed:
      return 0;
    case TourOutcome::completed_with_skips:
      return 3;
    case TourOutcome::interrupted:
      return 130;
    case TourOutcome::aborted:
    case TourOutcome::running:
      return 1;
  }
  return 1;
}

double time_of_day_at_zero_s(const host::MissionSchedule& schedule, bool dry_run,
                             double mission_now_s) {
  if (dry_run) return schedule.start_s;
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  const double day_s = local.tm_hour * 3600.0 + local.tm_min * 60.0 + local.tm_sec;
  return day_s - mission_now_s;
}

BehaviourInstances create_behaviours(const Machine& machine, const BehaviourCatalog& catalog,
                                     const RunContext& run) {
  BehaviourInstances out;
  for (const StateSpec* leaf : machine.leaves()) {
    try {
      out[leaf->path] = catalog.create_behaviour(leaf->behaviour, leaf->params, run);
    } catch (const std::exception& e) {
      throw std::runtime_error("state " + leaf->path + ": " + e.what());
    }
    if (!out[leaf->path]) {
      throw std::runtime_error("state " + leaf->path + ": kind \"" + leaf->behaviour +
                               "\" made no behaviour");
    }
  }
  return out;
}

Executor::Executor(Machine machine, BehaviourInstances behaviours,
                   std::vector<ServiceInstance> services, RunContext& run, SteppedClock& clock,
                   ExecutorOptions options)
    : machine_(std::move(machine)),
      behaviours_(std::move(behaviours)),
      services_(std::move(services)),
      run_(run),
      clock_(clock),
      options_(options) {
  if (run_.mission == nullptr || run_.blackboard == nullptr) {
    throw std::invalid_argument("Executor needs a mission and a blackboard in the RunContext");
  }
  if (run_.clock == nullptr) run_.clock = &clock_;
  for (const StateSpec* leaf : machine_.leaves()) {
    if (!behaviours_.count(leaf->path) || !behaviours_[leaf->path]) {
      throw std::invalid_argument("no behaviour for state " + leaf->path);
    }
  }
}

std::size_t Executor::target_count() const {
  return run_.mission->targets.size();
}

std::string Executor::active_state() const {
  if (active_.empty() || !active_.back()->is_leaf()) return "";
  return active_.back()->path;
}

void Executor::restore(std::vector<TargetRecord> done, std::optional<std::size_t> first_target,
                       int round) {
  round_ = std::max(1, round);
  for (auto& r : done) {
    // A record of an unscheduled run (round 0) belongs to the first round.
    if (std::max(1, r.round) == round_) done_.insert(r.index);
    records_.push_back(std::move(r));
  }
  first_target_ = first_target;
}

Context Executor::make_context(const StateSpec* leaf) const {
  Context ctx;
  ctx.run = &run_;
  if (current_target_) {
    ctx.target = visit_target_ ? &*visit_target_ : &run_.mission->targets[*current_target_];
    ctx.target_index = *current_target_;
    if (!run_.run_dir.empty()) ctx.target_dir = run_.run_dir / "targets" / ctx.target->id;
  }
  ctx.params = leaf != nullptr ? &leaf->params : nullptr;
  ctx.cancel = &cancel_;
  ctx.state_path = leaf != nullptr ? leaf->path : "";
  ctx.state_timer = leaf != nullptr ? &leaf_timer_ : nullptr;
  return ctx;
}

void Executor::emit(EventType type, const StateSpec& state, const std::string& outcome,
                    const std::string& message, const std::string& to) {
  ExecutorEvent e;
  e.t_s = clock_.now_s();
  e.type = type;
  e.state = state.path;
  if (current_target_ && visit_state_ != nullptr &&
      (state.path == visit_state_->path ||
       state.path.compare(0, visit_state_->path.size() + 1, visit_state_->path + "/") == 0)) {
    e.target = run_.mission->targets[*current_target_].id;
  }
  e.outcome = outcome;
  e.message = message;
  e.to = to;
  publish(e);
}

void Executor::publish(ExecutorEvent& event) {
  if (options_.schedule.written) event.round = round_;
  for (ExecutorObserver* o : observers_) o->on_event(event);
}

bool Executor::start_services() {
  start_s_ = clock_.now_s();
  service_contexts_.reserve(services_.size());
  for (auto& s : services_) {
    service_contexts_.push_back(make_context(nullptr));
    service_contexts_.back().state_path = "service/" + s.role;
    service_contexts_.back().params = &s.params;
  }
  for (std::size_t i = 0; i < services_.size(); ++i) {
    try {
      services_[i].service->start(service_contexts_[i]);
    } catch (const std::exception& e) {
      // Services started so far are stopped by finish_tour.
      service_contexts_.resize(i);
      abort_tour("service " + services_[i].role + " failed to start: " + e.what());
      return false;
    }
  }
  return true;
}

void Executor::start() {
  if (started_) return;
  started_ = true;
  if (start_services()) {
    enter(machine_.root());
    process_requests();
  }
}

void Executor::start_at(const std::string& state_path, std::size_t target_index) {
  const StateSpec* state = machine_.find(state_path);
  if (state == nullptr) throw std::invalid_argument("no state " + state_path);
  if (target_index >= target_count() && state->enclosing_for_each() != nullptr) {
    throw std::invalid_argument("no target " + std::to_string(target_index));
  }
  started_ = true;
  if (!start_services()) return;
  std::vector<const StateSpec*> chain;
  for (const StateSpec* s = state; s != nullptr; s = s->parent) chain.insert(chain.begin(), s);
  for (std::size_t i = 0; i + 1 < chain.size(); ++i) {
    const StateSpec* s = chain[i];
    if (s->for_each_target) {
      start_target_visit(*s, target_index);
      continue;
    }
    active_.push_back(s);
    emit(EventType::enter, *s);
  }
  if (state->for_each_target) first_target_ = target_index;
  enter(*state);
  process_requests();
}

void Executor::request_enter(const StateSpec& state) {
  requests_.push_back(Request{&state, std::nullopt});
}

void Executor::request_leaf_end(Outcome outcome) {
  requests_.push_back(Request{nullptr, std::move(outcome)});
}

// Transitions run one request at a time from a queue, so a chain of states that end at once
// (every start throwing, say) is a bounded loop here rather than a recursion.
void Executor::process_requests() {
  const std::size_t transitions_before = transition_count_;
  while (!requests_.empty() && !finished_) {
    if (transition_count_ - transitions_before > kMaxTransitionsPerTick) {
      const std::string where = active_.empty() ? machine_.root().path : active_.back()->path;
      requests_.clear();
      abort_tour(where + ": more than " + std::to_string(kMaxTransitionsPerTick) +
                 " transitions without a tick (a loop of states that end at once)");
      break;
    }
    Request request = std::move(requests_.front());
    requests_.pop_front();
    if (request.enter != nullptr) {
      enter(*request.enter);
    } else if (request.leaf_end) {
      follow_leaf_outcome(std::move(*request.leaf_end));
    }
  }
  requests_.clear();
}

void Executor::enter(const StateSpec& state) {
  if (finished_) return;
  switch (state.type) {
    case StateType::leaf:
      enter_leaf(state);
      return;
    case StateType::final_state:
      emit(EventType::enter, state);
      emit(EventType::exit, state);
      exit_composite(*state.parent);
      return;
    case StateType::composite:
      if (state.for_each_target) {
        visit_next_target(state);
        return;
      }
      active_.push_back(&state);
      emit(EventType::enter, state);
      enter(*state.child(state.initial));
      return;
  }
}

void Executor::enter_leaf(const StateSpec& state) {
  active_.push_back(&state);
  emit(EventType::enter, state);
  leaf_behaviour_ = behaviours_.at(state.path).get();
  leaf_timer_.restart(clock_.now_s());
  leaf_ctx_ = make_context(&state);
  leaf_entry_writes_ = run_.blackboard->writes();
  try {
    leaf_behaviour_->start(leaf_ctx_);
  } catch (const std::exception& e) {
    request_leaf_end(Outcome{kOutcomeFailed, std::string("start failed: ") + e.what()});
  }
}

// Stops the active leaf and pops it; measurements of the visit are taken here.
void Executor::stop_leaf(const Outcome& outcome) {
  const StateSpec* leaf = active_.back();
  emit(EventType::outcome, *leaf, outcome.name, outcome.message);
  try {
    leaf_behaviour_->stop(leaf_ctx_);
  } catch (const std::exception& e) {
    if (run_.log != nullptr) run_.log->warning(leaf->path + ": stop failed: " + e.what());
  }
  if (current_target_) measure_step_results(leaf_ctx_, leaf_entry_writes_, record_.measurements);
  if (!leaf->projected_on.empty() && outcome.name == leaf->projected_on) visit_projected_ = true;
  emit(EventType::exit, *leaf);
  active_.pop_back();
  leaf_behaviour_ = nullptr;
}

void Executor::follow_leaf_outcome(Outcome outcome) {
  const StateSpec* leaf = active_.back();
  const bool known = outcome.name == kOutcomeFailed || leaf->transition(outcome.name) != nullptr;
  if (!known) {
    outcome = Outcome{kOutcomeFailed,
                      "behaviour returned an outcome it does not declare: \"" + outcome.name +
                          "\"" + (outcome.message.empty() ? "" : " (" + outcome.message + ")")};
  }
  stop_leaf(outcome);
  const TransitionSpec* t = leaf->transition(outcome.name);
  const std::string reason = outcome.name + (outcome.message.empty() ? "" : ": " + outcome.message);
  if (t == nullptr) {
    abort_tour(leaf->path + " ended with \"" + outcome.name + "\", which has no transition (" +
               reason + ")");
    return;
  }
  follow(*leaf, *t, reason);
}

void Executor::follow(const StateSpec& from, const TransitionSpec& transition,
                      const std::string& reason) {
  std::string chosen;
  const StateSpec* next = nullptr;
  for (const auto& target : transition.targets) {
    if (is_reserved_target(target)) {
      chosen = target;
      break;
    }
    const StateSpec* s = from.parent->child(target);
    if (s == nullptr) continue;
    if (!transition.retry || retries_used_[s->path] < s->retries) {
      if (transition.retry) ++retries_used_[s->path];
      chosen = target;
      next = s;
      break;
    }
  }
  std::string why = reason;
  if (chosen.empty()) {
    chosen = from.parent->enclosing_for_each() != nullptr ? kSkipTarget : kAbort;
    std::string names;
    for (const auto& t : transition.targets) names += (names.empty() ? "" : ", ") + t;
    why = "retries exhausted (" + names + ") after " + reason;
  }
  ++transition_count_;
  emit(EventType::transition, from, transition.outcome, "", next != nullptr ? next->path : chosen);
  if (next != nullptr) {
    request_enter(*next);
  } else if (chosen == kSkipTarget) {
    record_visit_then_next("skipped", why);
  } else if (chosen == kDeferTarget) {
    defer_visit(why);
  } else if (chosen == kAbort) {
    abort_tour(from.path + ": " + why);
  } else {
    exit_composite(*from.parent);
  }
}

void Executor::exit_composite(const StateSpec& composite) {
  if (composite.for_each_target) {
    record_visit_then_next("projected", "");
    return;
  }
  unwind_to(&composite);
  active_.pop_back();
  emit(EventType::exit, composite);
  follow_composite_done(composite);
}

void Executor::follow_composite_done(const StateSpec& composite) {
  emit(EventType::outcome, composite, kOutcomeDone);
  if (composite.parent == nullptr) {
    // A target passed over for its hours is the schedule at work, not a skip.
    const bool all_projected = std::all_of(records_.begin(), records_.end(), [](const auto& r) {
      return r.outcome == "projected" || r.outcome == "outside_hours";
    });
    finish_tour(all_projected ? TourOutcome::completed : TourOutcome::completed_with_skips);
    return;
  }
  const TransitionSpec* t = composite.transition(kOutcomeDone);
  if (t == nullptr) {
    abort_tour(composite.path + " completed but has no transition for \"done\"");
    return;
  }
  follow(composite, *t, kOutcomeDone);
}

// Pops (with exit events) every active state above `keep`.
void Executor::unwind_to(const StateSpec* keep) {
  while (!active_.empty() && active_.back() != keep) {
    const StateSpec* s = active_.back();
    active_.pop_back();
    emit(EventType::exit, *s);
  }
}

void Executor::abort_tour(const std::string& reason) {
  abort_reason_ = reason;
  if (current_target_ && visit_state_ != nullptr) record_visit("failed", reason);
  unwind_to(nullptr);
  finish_tour(TourOutcome::aborted);
}

// A visit interrupted before its content was shown is not recorded: a resume restarts it from
// its first state. One interrupted after `project` succeeded (while `next` stows the head) is
// recorded as projected, so a resume does not project it a second time.
void Executor::interrupt() {
  if (current_target_ && visit_state_ != nullptr && visit_projected_) record_visit("projected", "");
  unwind_to(nullptr);
  finish_tour(TourOutcome::interrupted);
}

void Executor::finish_tour(TourOutcome outcome) {
  if (finished_) return;
  finished_ = true;
  outcome_ = outcome;
  for (std::size_t i = 0; i < services_.size() && i < service_contexts_.size(); ++i) {
    try {
      services_[i].service->stop(service_contexts_[i]);
    } catch (const std::exception& e) {
      if (run_.log != nullptr) run_.log->warning("service " + services_[i].role + ": " + e.what());
    }
  }
  if (run_.drivers != nullptr) {
    for (const auto& d : run_.drivers->all()) d->safe_stop();
  }
}

bool Executor::step() {
  if (!started_) start();
  if (finished_) return false;
  // Set, not accumulated, so mission time has no drift from summing tick_s. A pause stops it:
  // the tour's time is what the tour spent, and the devices see the same instant until it
  // goes on.
  if (!paused_) ++ticks_;
  clock_.set(start_s_ + static_cast<double>(ticks_) * options_.tick_s);
  const double now_s = clock_.now_s();
  driver_failure_.clear();
  if (run_.drivers != nullptr) {
    for (const auto& d : run_.drivers->all()) {
      try {
        d->update(now_s);
      } catch (const std::exception& e) {
        driver_failure_ = std::string("driver update failed: ") + e.what();
      }
    }
  }
  for (std::size_t i = 0; i < services_.size(); ++i) {
    try {
      services_[i].service->update(service_contexts_[i]);
    } catch (const std::exception& e) {
      driver_failure_ = "service " + services_[i].role + " failed: " + e.what();
    }
  }
  if (paused_ && (cancel_requested_ || skip_reason_) && leaf_behaviour_ != nullptr) {
    // The paused behaviour has made itself safe (projector blank, head holding, base still).
    // Resuming it only to cancel it would re-show its last frame or re-command its head goal
    // for a tick, so it is stopped as it stands: stop() is the one call every behaviour must
    // handle in any state. No grace period either: nothing is running that could finish.
    paused_ = false;
    cancel_.request();
    stop_leaf(Outcome{kOutcomeCancelled, "cancelled while paused"});
    const bool skipping = skip_reason_ && !cancel_requested_;
    after_cancelled_leaf();
    // The operator paused for a reason: skipping the visit does not also resume the tour.
    if (skipping) pause();
    return !finished_;
  }
  if (waiting_for_each_ != nullptr && leaf_behaviour_ == nullptr) {
    // Between rounds nothing is active: a cancel ends the tour at once.
    if (cancel_requested_) {
      interrupt();
    } else if (now_s >= next_round_s_ - 1e-9) {
      start_next_round();
      process_requests();
    }
    return !finished_;
  }
  if (paused_ || leaf_behaviour_ == nullptr) return !finished_;

  if (cancel_requested_ && !cancel_.requested()) {
    cancel_.request();
    cancel_started_s_ = now_s;
  }
  std::optional<Outcome> outcome;
  try {
    outcome = leaf_behaviour_->tick(leaf_ctx_);
  } catch (const std::exception& e) {
    outcome = Outcome{kOutcomeFailed, e.what()};
  } catch (...) {
    outcome = Outcome{kOutcomeFailed, "unknown exception"};
  }

  if (cancel_.requested()) {
    if (outcome) {
      stop_leaf(*outcome);
      after_cancelled_leaf();
    } else if (now_s - cancel_started_s_ >= options_.cancel_grace_s - 1e-9) {
      const StateSpec* leaf = active_.back();
      ignored_cancel_.push_back(leaf->path + " (" + leaf->behaviour + ")");
      if (run_.log != nullptr) {
        run_.log->warning("behaviour " + leaf->behaviour + " in " + leaf->path +
                          " ignored the cancel; stopped after the grace period");
      }
      stop_leaf(Outcome{kOutcomeCancelled, "ignored the cancel; stopped after " +
                                               std::to_string(options_.cancel_grace_s) + " s"});
      after_cancelled_leaf();
    }
    return !finished_;
  }

  const StateSpec* leaf = active_.back();
  if (!outcome && !driver_failure_.empty()) outcome = Outcome{kOutcomeFailed, driver_failure_};
  if (!outcome && leaf->timeout_s > 0 && leaf_timer_.elapsed_s(now_s) >= leaf->timeout_s - 1e-9) {
    outcome =
        Outcome{kOutcomeTimeout, "no outcome within " + json_number_text(leaf->timeout_s) + " s"};
  }
  if (outcome) {
    if (outcome->name == kOutcomeCancelled) {
      outcome = Outcome{kOutcomeFailed, "returned \"cancelled\" without a cancel request"};
    }
    request_leaf_end(std::move(*outcome));
    process_requests();
  }
  return !finished_;
}

TourOutcome Executor::run_to_end() {
  while (step()) {
  }
  return outcome_;
}

}  // namespace projtour
