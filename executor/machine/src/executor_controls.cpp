// The Executor's controls between ticks: pause and resume, the tour's cancel, and the operator's
// requests by name (skip the visit, retry a target), each recorded as a `control` event.
#include <algorithm>

#include "projtour/machine/executor.hpp"

namespace projtour {

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
    record_visit_then_next(visit_projected_ ? "projected" : "skipped",
                           visit_projected_ ? "" : reason);
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
