#include "projtour/record/events.hpp"

#include <stdexcept>

namespace projtour {

const char* to_string(EventType type) {
  switch (type) {
    case EventType::enter:
      return "enter";
    case EventType::exit:
      return "exit";
    case EventType::outcome:
      return "outcome";
    case EventType::transition:
      return "transition";
    case EventType::control:
      return "control";
    case EventType::round:
      return "round";
  }
  return "?";
}

void to_json(Json& j, const ExecutorEvent& event) {
  j = Json::object();
  j["t"] = event.t_s;
  j["event"] = to_string(event.type);
  j["state"] = event.state;
  j["target"] = event.target ? Json(*event.target) : Json();
  if (event.round > 0) j["round"] = event.round;
  const bool outcome = event.type == EventType::outcome || event.type == EventType::round;
  const bool transition = event.type == EventType::transition;
  if (outcome || transition) j["outcome"] = event.outcome;
  if (outcome && !event.message.empty()) j["message"] = event.message;
  if (transition) j["to"] = event.to;
  if (event.type == EventType::control) {
    j["request"] = event.request;
    j["by"] = event.by;
    j["accepted"] = event.accepted;
    if (!event.retry_target.empty()) j["retry_target"] = event.retry_target;
    if (!event.message.empty()) j["message"] = event.message;
  }
}

ExecutorObserver::~ExecutorObserver() = default;

JsonlEventWriter::JsonlEventWriter(const std::filesystem::path& file) : out_(file) {}

void JsonlEventWriter::on_event(const ExecutorEvent& event) {
  if (!error_.empty()) return;
  try {
    out_.append(dump_json(Json(event)) + '\n');
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

}  // namespace projtour
