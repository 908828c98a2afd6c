#pragma once
// What the executor tells its observers: every enter, exit, outcome and transition, and every
// finished target. events.jsonl, the progress display and the tests' recorder are observers.
#include <fstream>
#include <optional>
#include <string>

#include "projtour_executor/json_io.hpp"
#include "projtour_executor/target_record.hpp"

namespace projtour {

enum class EventType { enter, exit, outcome, transition };
const char* to_string(EventType type);

struct ExecutorEvent {
  double t_s = 0.0;  // mission time
  EventType type = EventType::enter;
  std::string state;  // "tour/visit/align"
  std::optional<std::string> target;
  std::string outcome;  // outcome and transition events
  std::string message;  // outcome events: why
  std::string to;       // transition events: a state path or skip_target/finish/abort
};

// The events.jsonl line is dump_json of this.
void to_json(Json& j, const ExecutorEvent& event);

class ExecutorObserver {
 public:
  virtual ~ExecutorObserver();
  virtual void on_event(const ExecutorEvent& event) { (void)event; }
  virtual void on_target_done(const TargetRecord& record) { (void)record; }
};

// events.jsonl: one object per line, flushed per line so an interrupted run keeps its events.
class JsonlEventWriter : public ExecutorObserver {
 public:
  // append: continue a file (resume).
  JsonlEventWriter(const std::filesystem::path& file, bool append);
  void on_event(const ExecutorEvent& event) override;

 private:
  std::ofstream out_;
};

}  // namespace projtour
