#pragma once
// A tour step. Life: start(ctx) -> tick(ctx) until it returns an outcome -> stop(ctx).
#include <optional>
#include <string>

#include "projtour/contract/context.hpp"

namespace projtour {

struct Outcome {
  std::string name;     // one of the outcomes the kind declares, or "failed" / "cancelled"
  std::string message;  // why, for the report and the events
};

// Outcomes every behaviour may end with without declaring them.
inline constexpr const char* kOutcomeFailed = "failed";
inline constexpr const char* kOutcomeCancelled = "cancelled";

class Behaviour {
 public:
  virtual ~Behaviour();
  virtual void start(Context& ctx) = 0;
  // nullopt while running. Should return within a tick's worth of work; long computations are
  // split over ticks. A throw ends the state with outcome "failed" carrying the message.
  virtual std::optional<Outcome> tick(Context& ctx) = 0;
  // Always called after the last tick, also after cancel or a throw, and straight after
  // pause() when a paused state is cancelled (no resume, no tick in between). Leaves devices
  // safe: projector blank, head and base still.
  virtual void stop(Context& ctx);
  // Cancel is cooperative: ctx.cancel_requested() turns true and tick should return
  // "cancelled" soon (it may take several ticks).
  // No tick between pause and resume; ctx.state_elapsed_s() stands still meanwhile.
  virtual void pause(Context& ctx);
  virtual void resume(Context& ctx);
};

// Lives for the whole tour (localization): updated every tick before the behaviour.
class Service {
 public:
  virtual ~Service();
  virtual void start(Context& ctx) = 0;
  virtual void update(Context& ctx) = 0;
  virtual void stop(Context& ctx);
};

}  // namespace projtour
