// The smallest useful behaviour: says hello, waits `duration_s` of mission time, succeeds.
// Copy this folder to start a plugin of your own.
#include <string>

#include "projtour/contract/plugin_author.hpp"

namespace {

class Hello : public projtour::Behaviour {
 public:
  // Parameters arrive complete and type-checked against kParams below; throwing here fails the
  // mission's validation with this message.
  Hello(const projtour::Params& params, const projtour::RunContext&)
      : duration_s_(params.number("duration_s")), greeting_(params.string("greeting")) {}

  void start(projtour::Context& ctx) override {
    started_s_ = ctx.state_elapsed_s();
    ctx.log().info(greeting_ + " (" + ctx.state_path + ")");
  }

  std::optional<projtour::Outcome> tick(projtour::Context& ctx) override {
    // Cancel is cooperative: answer it on the next tick.
    if (ctx.cancel_requested()) return projtour::Outcome{projtour::kOutcomeCancelled, "cancelled"};
    // Mission time only (never the system clock), so dry runs may run faster than real time;
    // state time, which leaves pauses out, so a pause does not shorten the wait.
    if (ctx.state_elapsed_s() - started_s_ < duration_s_) return std::nullopt;
    return projtour::Outcome{"succeeded", greeting_};
  }

 private:
  double duration_s_;
  std::string greeting_;
  double started_s_ = 0.0;
};

// Checked when the mission is loaded, before anything moves.
int validate(const void* params, char* error, size_t error_size) {
  const auto& p = *static_cast<const projtour::Params*>(params);
  if (p.number("duration_s") < 0.0) {
    projtour::plugin_detail::copy_message("duration_s must not be negative", error, error_size);
    return 1;
  }
  return 0;
}

const projtour_param_desc kParams[] = {
    {"duration_s", "number", "1.0", "mission time to wait before succeeding"},
    {"greeting", "string", "hello", "logged when the state starts"},
};
// "failed" and "cancelled" are implicit.
const char* const kOutcomes[] = {"succeeded"};

const projtour_kind_desc kKinds[] = {
    projtour::behaviour_kind<Hello>("hello", "logs a greeting, waits, then succeeds", kParams,
                                    kOutcomes, &validate),
};

}  // namespace

PROJTOUR_PLUGIN("hello", "1.0.0", kKinds)
