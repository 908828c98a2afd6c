#include "scripted_behaviour.hpp"

#include <chrono>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/context.hpp"

namespace projtour::testing {

namespace {

std::vector<std::string> split_outcomes(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto first = item.find_first_not_of(" \t");
    const auto last = item.find_last_not_of(" \t");
    out.push_back(first == std::string::npos ? "" : item.substr(first, last - first + 1));
  }
  return out;
}

}  // namespace

const projtour_param_desc kScriptedParams[6] = {
    {param::kOutcomes, "string", "succeeded",
     "comma-separated outcomes of successive runs; the last repeats"},
    {param::kTicks, "integer", "1", "ticks each run lasts (the outcome comes on the last)"},
    {param::kThrowOn, "integer", "0", "run number whose first tick throws (0 = never)"},
    {param::kIgnoreCancel, "boolean", "false", "keep running after a cancel request"},
    {param::kBlockOn, "integer", "0",
     "run number whose first tick never returns, as a hung driver call would (0 = never)"},
    {param::kMessage, "string", "", "message attached to each outcome"},
};

const std::vector<ParamSpec>& scripted_param_specs() {
  static const std::vector<ParamSpec> kSpecs = [] {
    std::vector<ParamSpec> specs;
    for (const auto& d : kScriptedParams) {
      ParamSpec spec;
      spec.name = d.name;
      param_type_from_string(d.type, spec.type);
      spec.default_value = d.default_value;
      spec.description = d.description;
      specs.push_back(spec);
    }
    return specs;
  }();
  return kSpecs;
}

std::string validate_script(const Params& params) {
  if (params.integer(param::kTicks) < 1) return "ticks must be at least 1";
  if (params.integer(param::kThrowOn) < 0) return "throw_on must be >= 0";
  for (const auto& o : split_outcomes(params.string(param::kOutcomes))) {
    if (o.empty()) return "outcomes has an empty entry";
  }
  return "";
}

ScriptedBehaviour::ScriptedBehaviour(const Params& params, const RunContext&)
    : outcomes_(split_outcomes(params.string(param::kOutcomes))),
      ticks_(params.integer(param::kTicks)),
      throw_on_(params.integer(param::kThrowOn)),
      block_on_(params.integer(param::kBlockOn)),
      ignore_cancel_(params.boolean(param::kIgnoreCancel)),
      message_(params.string(param::kMessage)) {
  const std::string why = validate_script(params);
  if (!why.empty()) throw std::invalid_argument(why);
}

void ScriptedBehaviour::start(Context&) {
  ++runs_;
  ticks_this_run_ = 0;
  paused_ = false;
}

std::optional<Outcome> ScriptedBehaviour::tick(Context& ctx) {
  ++total_ticks_;
  if (paused_) throw std::logic_error("ticked while paused");
  if (block_on_ == runs_ && ticks_this_run_ == 0) {
    // Only the executor's watchdog ends this.
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  if (throw_on_ == runs_ && ticks_this_run_ == 0) {
    ++ticks_this_run_;
    throw std::runtime_error("scripted failure on run " + std::to_string(runs_));
  }
  if (ctx.cancel_requested() && !ignore_cancel_) return Outcome{kOutcomeCancelled, "cancelled"};
  if (++ticks_this_run_ < ticks_) return std::nullopt;
  const std::size_t k =
      std::min<std::size_t>(static_cast<std::size_t>(runs_ - 1), outcomes_.size() - 1);
  Outcome outcome{outcomes_[k], message_};
  if (ignore_cancel_ && ctx.cancel_requested()) return std::nullopt;
  return outcome;
}

void ScriptedBehaviour::stop(Context&) {
  ++stops_;
}
void ScriptedBehaviour::pause(Context&) {
  ++pauses_;
  paused_ = true;
}
void ScriptedBehaviour::resume(Context&) {
  ++resumes_;
  paused_ = false;
}

}  // namespace projtour::testing
