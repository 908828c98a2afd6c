#pragma once
// A behaviour that plays a script, for state-machine tests and the scripted demo tour: on its
// n-th run (start) it returns the n-th outcome of `outcomes` (the last one repeats) after
// `ticks` ticks, throws in tick on run `throw_on`, and may ignore a cancel.
#include <string>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/contract/plugin_abi.h"

namespace projtour::testing {
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kOutcomes = "outcomes";
inline constexpr const char* kTicks = "ticks";
inline constexpr const char* kThrowOn = "throw_on";
inline constexpr const char* kIgnoreCancel = "ignore_cancel";
inline constexpr const char* kBlockOn = "block_on";
inline constexpr const char* kMessage = "message";
}  // namespace param

// The schema every scripted kind shares, as the plugin ABI gives it and as the executor reads it.
extern const projtour_param_desc kScriptedParams[6];
const std::vector<ParamSpec>& scripted_param_specs();
// "" when the script is well formed; checked at mission load.
std::string validate_script(const Params& params);

class ScriptedBehaviour : public Behaviour {
 public:
  ScriptedBehaviour(const Params& params, const RunContext& run);

  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;
  void stop(Context& ctx) override;
  void pause(Context& ctx) override;
  void resume(Context& ctx) override;

  int runs() const { return runs_; }
  int stops() const { return stops_; }
  int pauses() const { return pauses_; }
  int resumes() const { return resumes_; }
  int ticks_seen() const { return total_ticks_; }

 private:
  std::vector<std::string> outcomes_;
  long long ticks_ = 1;
  long long throw_on_ = 0;
  long long block_on_ = 0;
  bool ignore_cancel_ = false;
  std::string message_;
  int runs_ = 0;
  long long ticks_this_run_ = 0;
  int stops_ = 0;
  int pauses_ = 0;
  int resumes_ = 0;
  int total_ticks_ = 0;
  bool paused_ = false;
};

}  // namespace projtour::testing
