#pragma once
// What the executor tells its observers: every enter, exit, outcome and transition, and every
// finished target. events.jsonl, the progress display and the tests' recorder are observers.
#include <optional>
#include <string>

#include "projtour/contract/run_files.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/record/target_record.hpp"

namespace projtour {

// round: a round of a schedule begins or ends (outcome "begin" | "end", message when and how it
// went).
enum class EventType { enter, exit, outcome, transition, control, round };
const char* to_string(EventType type);

struct ExecutorEvent {
  double t_s = 0.0;  // mission time
  EventType type = EventType::enter;
  std::string state;  // "tour/visit/align"
  std::optional<std::string> target;
  std::string outcome;  // outcome and transition events
  std::string message;  // outcome events: why
  std::string to;       // transition events: a state path or skip_target/finish/abort
  // control events: what was asked (pause, resume, cancel, skip, retry), by whom (operator,
  // signal), whether it was done (`message` says why not, or what), and retry's target.
  std::string request;
  std::string by;
  bool accepted = false;
  std::string retry_target;
  // The schedule's round the event happened in (1, 2, ...); 0, and not written, without one.
  int round = 0;
};

// The events.jsonl line is dump_json of this.
void to_json(Json& j, const ExecutorEvent& event);

class ExecutorObserver {
 public:
  virtual ~ExecutorObserver();
  virtual void on_event(const ExecutorEvent& event) { (void)event; }
  virtual void on_target_done(const TargetRecord& record) { (void)record; }
};

// events.jsonl: one object per line, each written whole so an interrupted run keeps its events.
// The file is only ever appended to (a resumed run continues it; a fresh run's directory holds
// none). A write that fails is not retried: error() says why, for the run to end on it.
class JsonlEventWriter : public ExecutorObserver {
 public:
  explicit JsonlEventWriter(const std::filesystem::path& file);  // throws std::runtime_error
  void on_event(const ExecutorEvent& event) override;
  const std::string& error() const { return error_; }

 private:
  AppendOnlyFile out_;
  std::string error_;
};

}  // namespace projtour
