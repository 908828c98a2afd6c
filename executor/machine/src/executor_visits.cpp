// The Executor's visits of the for_each's targets and the schedule's rounds: which target is
// next, a visit's start and its record, a visit left for later, the passes over targets outside
// their hours and each round's begin and end (executor.cpp has the states and transitions).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/run_files.hpp"
#include "projtour/machine/executor.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace projtour {

namespace {

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
    planner_ =
        std::make_unique<navigation::PathPlanner>(*run_.map, run_.mission->robot.base.radius_m);
  }
  std::size_t chosen = remaining.front();
  double best_m = std::numeric_limits<double>::infinity();
  for (std::size_t i : remaining) {
    const Pose2D goal = navigation::standoff_pose(run_.mission->targets[i]);
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

void Executor::start_target_visit(const StateSpec& for_each, std::size_t index) {
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
    const host::TargetTimes& times = options_.target_times[index];
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

void Executor::visit_next_target(const StateSpec& for_each) {
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
    start_target_visit(for_each, *next);
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
  for (const host::TimeWindow& w : hours) {
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
  const host::MissionSchedule& schedule = options_.schedule;
  if (!schedule.written) {
    follow_composite_done(for_each);
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
    for (const host::TargetTimes& t : options_.target_times) {
      for (const host::TimeWindow& w : t.hours) {
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
    follow_composite_done(for_each);
    return;
  }
  waiting_for_each_ = &for_each;
  next_round_s_ = next_s;
}

void Executor::start_next_round() {
  const StateSpec* for_each = waiting_for_each_;
  waiting_for_each_ = nullptr;
  ++round_;
  done_.clear();
  deferred_.clear();
  visit_next_target(*for_each);
}

// Records the visit in progress as done with `outcome` and leaves its for_each state.
void Executor::record_visit(const std::string& outcome, const std::string& reason) {
  record_.outcome = outcome;
  record_.reason = reason;
  record_.retries = retries_taken();
  records_.push_back(record_);
  done_.insert(record_.index);
  exit_visit_state();
  for (ExecutorObserver* o : observers_) o->on_target_done(records_.back());
}

void Executor::exit_visit_state() {
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
    record_visit_then_next("skipped", reason + (deferred_.count(index) != 0
                                                    ? " (again, after it was left for later)"
                                                    : " (no other target left to visit first)"));
    return;
  }
  deferred_.insert(index);
  if (run_.log != nullptr) {
    run_.log->warning("target " + record_.id + ": left for later in the tour (" + reason + ")");
  }
  const StateSpec* for_each = visit_state_;
  exit_visit_state();
  visit_next_target(*for_each);
}

void Executor::record_visit_then_next(const std::string& outcome, const std::string& reason) {
  const StateSpec* for_each = visit_state_;
  record_visit(outcome, reason);
  visit_next_target(*for_each);
}

int Executor::retries_taken() const {
  int total = 0;
  for (const auto& kv : retries_used_) total += kv.second;
  return total;
}

}  // namespace projtour
