#include "projtour/machine/watchdog.hpp"

namespace projtour {

TickWatchdog::TickWatchdog(HangHandler on_hang)
    : on_hang_(std::move(on_hang)), thread_([this] { watch(); }) {}

TickWatchdog::~TickWatchdog() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void TickWatchdog::publish(TourSnapshot snapshot) {
  std::lock_guard<std::mutex> lock(mutex_);
  snapshot_ = std::move(snapshot);
}

void TickWatchdog::tick_started(const std::string& state, double limit_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_ = state;
  limit_s_ = limit_s;
  deadline_ = Clock::now() +
              std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(limit_s));
  armed_ = true;
  wake_.notify_all();
}

bool TickWatchdog::tick_finished() {
  std::unique_lock<std::mutex> lock(mutex_);
  // Decided under the lock: either the tick is done before the deadline is seen (and the
  // watchdog will not fire for it) or the watchdog has fired and this tick waits it out.
  if (!fired_) {
    armed_ = false;
    return true;
  }
  handled_.wait(lock, [this] { return handler_done_; });
  return false;
}

bool TickWatchdog::fired() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return fired_;
}

void TickWatchdog::watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!quit_) {
    if (!armed_) {
      wake_.wait(lock);
      continue;
    }
    if (Clock::now() < deadline_) {
      wake_.wait_until(lock, deadline_);
      continue;
    }
    fired_ = true;
    const std::string state = state_;
    const double limit_s = limit_s_;
    const TourSnapshot snapshot = snapshot_;
    lock.unlock();
    try {
      on_hang_(state, limit_s, snapshot);
    } catch (...) {
      // Nobody is left to tell: the handler is the last word of a hung tour.
    }
    lock.lock();
    handler_done_ = true;
    handled_.notify_all();
    return;
  }
}

}  // namespace projtour
