#include "projtour_executor/executor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "projtour/blackboard_keys.hpp"
#include "projtour/occupancy_map.hpp"
#include "projtour/run_files.hpp"
#include "projtour_executor/json_io.hpp"
#include "projtour_executor/measurements.hpp"

namespace projtour {

namespace {
constexpr std::size_t kMaxTransitionsPerTick = 1000;

// "HH:MM:SS" (or "HH:MM") of seconds after midnight, wrapped to the day.
std::string clock_text(double day_s, bool seconds = true) {
  // 24:00 stays 24:00 (a window's end); later times wrap to the next day.
  long total = static_cast<long>(std::floor(day_s));
  if (total > 86400) total %= 86400;
  char buf[64];
  if (seconds) {
    std::snprintf(buf, sizeof buf, "%02ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%02ld:%02ld", total / 3600, total / 60 % 60);
  }
  return buf;
}
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

double time_of_day_at_zero_s(const MissionSchedule& schedule, bool dry_run, double mission_now_s) {
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
      open_visit(*s, target_index);
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
      finish_leaf(std::move(*request.leaf_end));
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
      complete_composite(*state.parent);
      return;
    case StateType::composite:
      if (state.for_each_target) {
        begin_visit(state);
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

std::optional<std::size_t> Executor::choose_next_target(const StateSpec& for_each) {
  const std::size_t n = target_count();
  if (first_target_) {
    const std::size_t first = *first_target_;
    first_target_.reset();
    if (first < n && done_.count(first) == 0) return first;
  }
  // Deferred targets wait until every other one has had its visit.
  std::vector<std::size_t> remaining, deferred;
  for (std::size_t i = 0; i < n; ++i) {
    if (done_.count(i) != 0) continue;
    (deferred_.count(i) != 0 ? deferred : remaining).push_back(i);
  }
  if (remaining.empty()) remaining = deferred;
  if (remaining.empty()) return std::nullopt;
  const std::string& order = for_each.order.empty() ? run_.mission->order : for_each.order;
  if (order != "nearest") return remaining.front();
  const PoseEstimate2D* estimate = run_.blackboard->find(keys::kLocalization);
  if (estimate == nullptr) {
    if (run_.log != nullptr) {
      run_.log->warning("order nearest: no localization estimate yet; mission order");
    }
    return remaining.front();
  }
  return nearest_target(*estimate, remaining);
}

// The remaining target with the shortest path on the map (grid inflated by the robot's radius)
// from the estimate to its stand-off pose; ties and targets without a path keep mission order,
// so navigate reports the unreachable ones. A run without a map ranks by straight line.
std::size_t Executor::nearest_target(const PoseEstimate2D& estimate,
                                     const std::vector<std::size_t>& remaining) {
  const Eigen::Vector2d here(estimate.mean.x_m, estimate.mean.y_m);
  if (run_.map && !planner_) {
    planner_ = std::make_unique<PathPlanner>(*run_.map, run_.mission->robot.base.radius_m);
  }
  std::size_t chosen = remaining.front();
  double best_m = std::numeric_limits<double>::infinity();
  for (std::size_t i : remaining) {
    const Pose2D goal = standoff_pose(run_.mission->targets[i]);
    const Eigen::Vector2d to(goal.x_m, goal.y_m);
    const double length_m =
        planner_
            ? planner_->path_length_m(here, to).value_or(std::numeric_limits<double>::infinity())
            : (to - here).norm();
    if (length_m < best_m) {
      best_m = length_m;
      chosen = i;
    }
  }
  return chosen;
}

void Executor::open_visit(const StateSpec& for_each, std::size_t index) {
  current_target_ = index;
  visit_state_ = &for_each;
  retries_used_.clear();
  visit_projected_ = false;
  run_.blackboard->clear_visit();
  record_ = TargetRecord{};
  record_.index = index;
  record_.id = run_.mission->targets[index].id;
  record_.round = options_.schedule.written ? round_ : 0;
  visit_target_.reset();
  if (index < options_.target_times.size() && options_.target_times[index].content.size() > 1) {
    // Counted from the records, so a resumed run goes on with the item it would have shown.
    const TargetTimes& times = options_.target_times[index];
    const auto shown = std::count_if(records_.begin(), records_.end(), [&](const TargetRecord& r) {
      return r.index == index && r.outcome != "outside_hours";
    });
    const std::size_t k =
        static_cast<std::size_t>(times.per_round ? round_ - 1 : shown) % times.content.size();
    visit_target_ = run_.mission->targets[index];
    visit_target_->content = times.content[k];
    record_.content = times.content[k].filename().string();
    record_.content_index = static_cast<int>(k);
  }
  if (!run_.run_dir.empty()) {
    try {
      make_run_directory(run_.run_dir / "targets" / record_.id);
    } catch (const std::exception& e) {
      if (run_.log != nullptr) run_.log->warning(e.what());
    }
  }
  active_.push_back(&for_each);
  emit(EventType::enter, for_each);
}

void Executor::begin_visit(const StateSpec& for_each) {
  if (options_.schedule.written && !round_open_) {
    round_open_ = true;
    emit_round(for_each, "begin", "at " + clock_text(time_of_day_s(clock_.now_s())));
  }
  // Each pass records a target as done this round, so the loop ends within target_count().
  for (;;) {
    const auto next = choose_next_target(for_each);
    if (!next) {
      end_round(for_each);
      return;
    }
    if (const std::string why = outside_hours(*next); !why.empty()) {
      pass_over(for_each, *next, why);
      continue;
    }
    open_visit(for_each, *next);
    request_enter(*for_each.child(for_each.initial));
    return;
  }
}

std::string Executor::outside_hours(std::size_t index) const {
  if (index >= options_.target_times.size()) return "";
  const auto& hours = options_.target_times[index].hours;
  if (hours.empty()) return "";
  const double now = std::fmod(time_of_day_s(clock_.now_s()), 86400.0);
  std::string windows;
  for (const TimeWindow& w : hours) {
    if (now >= w.begin_s && now < w.end_s) return "";
    windows += (windows.empty() ? "" : ", ") + clock_text(w.begin_s, false) + "-" +
               clock_text(w.end_s, false);
  }
  return "outside its hours (" + windows + ") at " + clock_text(now);
}

void Executor::pass_over(const StateSpec& for_each, std::size_t index, const std::string& reason) {
  TargetRecord r;
  r.index = index;
  r.id = run_.mission->targets[index].id;
  r.outcome = "outside_hours";
  r.reason = reason;
  r.round = options_.schedule.written ? round_ : 0;
  records_.push_back(std::move(r));
  done_.insert(index);
  ExecutorEvent e;
  e.t_s = clock_.now_s();
  e.type = EventType::outcome;
  e.state = for_each.path;
  e.target = records_.back().id;
  e.outcome = "outside_hours";
  e.message = reason;
  publish(e);
  for (ExecutorObserver* o : observers_) o->on_target_done(records_.back());
}

void Executor::emit_round(const StateSpec& for_each, const std::string& outcome,
                          const std::string& message) {
  ExecutorEvent e;
  e.t_s = clock_.now_s();
  e.type = EventType::round;
  e.state = for_each.path;
  e.outcome = outcome;
  e.message = message;
  publish(e);
}

// The robot stays where the round left it for pause_s, or until a target's window opens when
// the round found every one closed (a pause of 0 would otherwise spin round after round).
void Executor::end_round(const StateSpec& for_each) {
  const MissionSchedule& schedule = options_.schedule;
  if (!schedule.written) {
    composite_done(for_each);
    return;
  }
  const double now_s = clock_.now_s();
  std::map<std::string, int> counts;
  bool visited = false;
  for (const TargetRecord& r : records_) {
    if (r.round != round_) continue;
    ++counts[r.outcome];
    visited |= r.outcome != "outside_hours";
  }
  std::string tally;
  for (const auto& [outcome, n] : counts) {
    tally += (tally.empty() ? "" : ", ") + std::to_string(n) + " " + outcome;
  }
  double next_s = now_s + schedule.pause_s;
  std::string last;
  if (!visited) {
    // The earliest window opening after now, today.
    const double day_s = std::fmod(time_of_day_s(now_s), 86400.0);
    std::optional<double> opens_s;
    for (const TargetTimes& t : options_.target_times) {
      for (const TimeWindow& w : t.hours) {
        if (w.begin_s > day_s && (!opens_s || w.begin_s < *opens_s)) opens_s = w.begin_s;
      }
    }
    if (opens_s) {
      next_s = std::max(next_s, now_s + (*opens_s - day_s));
    } else {
      last = "no target's hours open again today";
    }
  }
  if (last.empty() && schedule.rounds && round_ >= *schedule.rounds) {
    last = "the last of " + std::to_string(*schedule.rounds) + " rounds";
  } else if (last.empty() && schedule.until_s && time_of_day_s(next_s) >= *schedule.until_s) {
    last = "the next would begin at " + clock_text(time_of_day_s(next_s)) + ", not before " +
           clock_text(*schedule.until_s, false);
  }
  emit_round(for_each, "end",
             "at " + clock_text(time_of_day_s(now_s)) + ": " + (tally.empty() ? "nothing" : tally) +
                 "; " +
                 (last.empty() ? "the next begins at " + clock_text(time_of_day_s(next_s)) : last));
  round_open_ = false;
  if (!last.empty()) {
    composite_done(for_each);
    return;
  }
  waiting_for_each_ = &for_each;
  next_round_s_ = next_s;
}

void Executor::begin_round() {
  const StateSpec* for_each = waiting_for_each_;
  waiting_for_each_ = nullptr;
  ++round_;
  done_.clear();
  deferred_.clear();
  begin_visit(*for_each);
}

// Stops the active leaf and pops it; measurements of the visit are taken here.
void Executor::leave_leaf(const Outcome& outcome) {
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

void Executor::finish_leaf(Outcome outcome) {
  const StateSpec* leaf = active_.back();
  const bool known = outcome.name == kOutcomeFailed || leaf->transition(outcome.name) != nullptr;
  if (!known) {
    outcome = Outcome{kOutcomeFailed,
                      "behaviour returned an outcome it does not declare: \"" + outcome.name +
                          "\"" + (outcome.message.empty() ? "" : " (" + outcome.message + ")")};
  }
  leave_leaf(outcome);
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
    end_visit("skipped", why);
  } else if (chosen == kDeferTarget) {
    defer_visit(why);
  } else if (chosen == kAbort) {
    abort_tour(from.path + ": " + why);
  } else {
    complete_composite(*from.parent);
  }
}

void Executor::complete_composite(const StateSpec& composite) {
  if (composite.for_each_target) {
    end_visit("projected", "");
    return;
  }
  unwind_to(&composite);
  active_.pop_back();
  emit(EventType::exit, composite);
  composite_done(composite);
}

void Executor::composite_done(const StateSpec& composite) {
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

// Records the visit in progress as done with `outcome` and leaves its for_each state.
void Executor::close_visit(const std::string& outcome, const std::string& reason) {
  record_.outcome = outcome;
  record_.reason = reason;
  record_.retries = retries_taken();
  records_.push_back(record_);
  done_.insert(record_.index);
  leave_visit_state();
  for (ExecutorObserver* o : observers_) o->on_target_done(records_.back());
}

void Executor::leave_visit_state() {
  const StateSpec* for_each = visit_state_;
  unwind_to(for_each);
  active_.pop_back();
  emit(EventType::exit, *for_each);
  current_target_.reset();
  visit_state_ = nullptr;
}

// The visit ends unrecorded and its target goes after every other one left; the second time,
// or with nothing else left to visit first, it is skipped.
void Executor::defer_visit(const std::string& reason) {
  const std::size_t index = record_.index;
  bool others_left = false;
  for (std::size_t i = 0; i < target_count(); ++i) {
    others_left |= i != index && done_.count(i) == 0 && deferred_.count(i) == 0;
  }
  if (deferred_.count(index) != 0 || !others_left) {
    end_visit("skipped",
              reason + (deferred_.count(index) != 0 ? " (again, after it was left for later)"
                                                    : " (no other target left to visit first)"));
    return;
  }
  deferred_.insert(index);
  if (run_.log != nullptr) {
    run_.log->warning("target " + record_.id + ": left for later in the tour (" + reason + ")");
  }
  const StateSpec* for_each = visit_state_;
  leave_visit_state();
  begin_visit(*for_each);
}

void Executor::end_visit(const std::string& outcome, const std::string& reason) {
  const StateSpec* for_each = visit_state_;
  close_visit(outcome, reason);
  begin_visit(*for_each);
}

int Executor::retries_taken() const {
  int total = 0;
  for (const auto& kv : retries_used_) total += kv.second;
  return total;
}

void Executor::abort_tour(const std::string& reason) {
  abort_reason_ = reason;
  if (current_target_ && visit_state_ != nullptr) close_visit("failed", reason);
  unwind_to(nullptr);
  finish_tour(TourOutcome::aborted);
}

// A visit interrupted before its content was shown is not recorded: a resume restarts it from
// its first state. One interrupted after `project` succeeded (while `next` stows the head) is
// recorded as projected, so a resume does not project it a second time.
void Executor::interrupt() {
  if (current_target_ && visit_state_ != nullptr && visit_projected_) close_visit("projected", "");
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
    leave_leaf(Outcome{kOutcomeCancelled, "cancelled while paused"});
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
      begin_round();
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
      leave_leaf(*outcome);
      after_cancelled_leaf();
    } else if (now_s - cancel_started_s_ >= options_.cancel_grace_s - 1e-9) {
      const StateSpec* leaf = active_.back();
      ignored_cancel_.push_back(leaf->path + " (" + leaf->behaviour + ")");
      if (run_.log != nullptr) {
        run_.log->warning("behaviour " + leaf->behaviour + " in " + leaf->path +
                          " ignored the cancel; stopped after the grace period");
      }
      leave_leaf(Outcome{kOutcomeCancelled, "ignored the cancel; stopped after " +
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

void Executor::pause() {
  if (paused_ || finished_ || leaf_behaviour_ == nullptr) return;
  paused_ = true;
  leaf_timer_.pause(clock_.now_s());
  leaf_behaviour_->pause(leaf_ctx_);
}

void Executor::resume() {
  if (!paused_) return;
  paused_ = false;
  leaf_timer_.resume(clock_.now_s());
  if (leaf_behaviour_ != nullptr) leaf_behaviour_->resume(leaf_ctx_);
}

Executor::ControlReply Executor::control(const std::string& request, const std::string& by,
                                         const std::string& target) {
  ControlReply reply;
  if (finished_) {
    reply.message = "the tour has ended";
  } else if (request == "pause") {
    reply.accepted = leaf_behaviour_ != nullptr && !paused_;
    if (reply.accepted) pause();
    reply.message = reply.accepted ? "paused" : paused_ ? "already paused" : "no step is active";
  } else if (request == "resume") {
    reply.accepted = paused_;
    if (reply.accepted) resume();
    reply.message = reply.accepted ? "resumed" : "not paused";
  } else if (request == "cancel") {
    reply.accepted = !cancel_requested_;
    reply.message = reply.accepted ? "cancelling the tour" : "already cancelling";
  } else if (request == "skip") {
    reply = skip_current(by);
  } else if (request == "retry") {
    reply = retry_target(target);
  } else {
    reply.message = "unknown request \"" + request + "\"";
  }
  ExecutorEvent e;
  e.t_s = clock_.now_s();
  e.type = EventType::control;
  e.state = active_state();
  if (current_target_) e.target = run_.mission->targets[*current_target_].id;
  e.request = request;
  e.by = by;
  e.accepted = reply.accepted;
  e.message = reply.message;
  e.retry_target = request == "retry" ? target : "";
  publish(e);
  // After the event, so that the log reads: asked, then what it did.
  if (reply.accepted && request == "cancel") request_cancel();
  return reply;
}

Executor::ControlReply Executor::skip_current(const std::string& by) {
  if (!current_target_ || visit_state_ == nullptr || leaf_behaviour_ == nullptr) {
    return {false, "no target is being visited"};
  }
  if (skip_reason_ || cancel_requested_) return {false, "already ending this visit"};
  skip_reason_ = "skipped by " + by;
  cancel_.request();
  cancel_started_s_ = clock_.now_s();
  return {true, "skipping " + run_.mission->targets[*current_target_].id};
}

Executor::ControlReply Executor::retry_target(const std::string& id) {
  const auto& targets = run_.mission->targets;
  std::size_t index = targets.size();
  for (std::size_t i = 0; i < targets.size(); ++i) {
    if (targets[i].id == id) index = i;
  }
  if (index == targets.size()) return {false, "no target \"" + id + "\" in the mission"};
  if (current_target_ == index) return {false, id + " is being visited"};
  // This round's record: a scheduled tour keeps one per round, and earlier rounds are history.
  const auto record = std::find_if(records_.begin(), records_.end(), [&](const TargetRecord& r) {
    return r.index == index && (!options_.schedule.written || r.round == round_);
  });
  if (record == records_.end()) return {false, id + " has not been visited yet"};
  if (record->outcome == "projected") return {false, id + " was projected"};
  if (record->outcome == "outside_hours") return {false, id + " is outside its hours"};
  // A visit loop that has ended visits nothing more; only one still going can take it back.
  if (current_target_ == std::nullopt && visit_state_ == nullptr) {
    const bool visiting = std::any_of(active_.begin(), active_.end(),
                                      [](const StateSpec* s) { return s->for_each_target; });
    if (!visiting) return {false, "the targets' visits have ended"};
  }
  records_.erase(record);
  done_.erase(index);
  deferred_.erase(index);
  return {true, id + " will be visited again later in the tour"};
}

void Executor::after_cancelled_leaf() {
  if (skip_reason_ && !cancel_requested_ && current_target_ && visit_state_ != nullptr) {
    const std::string reason = *skip_reason_;
    skip_reason_.reset();
    cancel_.reset();
    // Content already shown stays shown: the visit is recorded as what it was.
    end_visit(visit_projected_ ? "projected" : "skipped", visit_projected_ ? "" : reason);
    process_requests();
    return;
  }
  skip_reason_.reset();
  interrupt();
}

void Executor::request_cancel() {
  if (finished_) return;
  cancel_requested_ = true;
  if (!started_) {
    started_ = true;
    finish_tour(TourOutcome::interrupted);
  }
}

}  // namespace projtour
