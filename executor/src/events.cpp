#include "projtour_executor/events.hpp"

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
  }
  return "?";
}

Json ExecutorEvent::to_json() const {
  Json j = Json::object();
  j.set("t", t_s);
  j.set("event", to_string(type));
  j.set("state", state);
  j.set("target", target ? Json(*target) : Json());
  if (type == EventType::outcome || type == EventType::transition) j.set("outcome", outcome);
  if (type == EventType::outcome && !message.empty()) j.set("message", message);
  if (type == EventType::transition) j.set("to", to);
  return j;
}

Json TargetRecord::to_json() const {
  Json j = Json::object();
  j.set("id", id);
  j.set("outcome", outcome);
  if (!reason.empty()) j.set("reason", reason);
  j.set("retries", retries);
  // DESIGN.md's order, whatever order the states exited in.
  static const char* const kOrder[] = {"projected_s",         "align",
                                       "localization_error",  "target_pose_error",
                                       "projection_error_mm", "projection_error_px"};
  for (const char* key : kOrder) {
    if (const Json* v = measurements.find(key)) j.set(key, *v);
  }
  for (const auto& kv : measurements.as_object()) {
    if (j.find(kv.first) == nullptr) j.set(kv.first, kv.second);
  }
  return j;
}

TargetRecord TargetRecord::from_json(const Json& json, std::size_t index) {
  TargetRecord r;
  r.index = index;
  r.id = json.at("id").as_string();
  r.outcome = json.at("outcome").as_string();
  if (const Json* reason = json.find("reason")) r.reason = reason->as_string();
  r.retries = static_cast<int>(json.at("retries").as_int());
  for (const auto& kv : json.as_object()) {
    if (kv.first != "id" && kv.first != "outcome" && kv.first != "reason" &&
        kv.first != "retries") {
      r.measurements.set(kv.first, kv.second);
    }
  }
  return r;
}

ExecutorObserver::~ExecutorObserver() = default;

JsonlEventWriter::JsonlEventWriter(const std::filesystem::path& file, bool append)
    : out_(file, append ? std::ios::app : std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write " + file.string());
}

void JsonlEventWriter::on_event(const ExecutorEvent& event) {
  out_ << event.to_json().dump() << '\n';
  out_.flush();
}

}  // namespace projtour
