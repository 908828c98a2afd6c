#pragma once
// A behaviour whose tick never returns would leave the robot moving and the projector lit with
// nothing in charge. The watchdog runs beside the tick loop; when one tick outlasts its limit
// (wall time) it calls its handler from its own thread, which in the command writes the report
// and ends the process.
//
// The handler never reads the executor: the stuck tick may return at any moment and go on
// changing it. It gets the snapshot the tick loop last published between ticks, under the
// watchdog's lock. And a tick that returns after the watchdog fired does not race the handler:
// tick_finished() waits until the handler is done and then says the tour is over.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "projtour/record/events.hpp"

namespace projtour {

// What the hang handler may know of the tour, as of the last tick that returned.
struct TourSnapshot {
  double mission_s = 0.0;
  // Shared and immutable: the loop makes a new one only when a target is done, so publishing
  // after every tick costs a pointer copy, not a copy of every record of a long day.
  std::shared_ptr<const std::vector<TargetRecord>> records =
      std::make_shared<const std::vector<TargetRecord>>();
  std::optional<std::size_t> current_target;
  std::vector<std::string> ignored_cancel;
};

class TickWatchdog {
 public:
  using HangHandler =
      std::function<void(const std::string& state, double limit_s, const TourSnapshot& last)>;
  explicit TickWatchdog(HangHandler on_hang);
  ~TickWatchdog();
  TickWatchdog(const TickWatchdog&) = delete;
  TickWatchdog& operator=(const TickWatchdog&) = delete;

  // Between ticks, from the tick loop: what the handler gets if a later tick hangs.
  void publish(TourSnapshot snapshot);
  void tick_started(const std::string& state, double limit_s);
  // True when the tick ended in time. False when the watchdog fired during it: returns only
  // once the handler has finished (the command's handler ends the process, so never there), and
  // the caller must leave the tour, its drivers and its files alone from then on.
  bool tick_finished();
  bool fired() const;

 private:
  using Clock = std::chrono::steady_clock;
  void watch();

  HangHandler on_hang_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable handled_;
  bool quit_ = false;
  bool armed_ = false;
  bool fired_ = false;
  bool handler_done_ = false;
  std::string state_;
  double limit_s_ = 0.0;
  Clock::time_point deadline_;
  TourSnapshot snapshot_;
  std::thread thread_;  // last: started once everything it reads is constructed
};

}  // namespace projtour
