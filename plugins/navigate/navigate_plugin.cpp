// Plugin `navigate`: behaviours navigate and relocalize.
#include "navigate.hpp"

#include <stdexcept>
#include <string>

#include "projtour/plugin_author.hpp"

namespace projtour::navigate {
namespace {

void check_navigate_params(const Params& p) {
  for (const char* name :
       {"tolerance_m", "tolerance_deg", "lookahead_m", "blocked_s", "timeout_s", "lost_std_m",
        "lost_unconverged_s", "obstacle_lookahead_m", "max_detour_m"}) {
    if (!(p.number(name) > 0.0)) {
      throw std::invalid_argument(std::string(name) + ": expected a positive number");
    }
  }
  if (!(p.number("reapproach_margin_px") >= 0.0)) {
    throw std::invalid_argument("reapproach_margin_px: expected a number >= 0");
  }
  if (!(p.number("reapproach_max_extra_m") >= 0.0 && p.number("reapproach_max_extra_m") <= 3.0)) {
    throw std::invalid_argument("reapproach_max_extra_m: expected a number in [0, 3]");
  }
}

const projtour_param_desc kNavigateParams[] = {
    {"tolerance_m", "number", "0.10", "succeed when the estimate is this close to the goal"},
    {"tolerance_deg", "number", "5", "and its heading this close"},
    {"lookahead_m", "number", "0.6", "pure pursuit lookahead distance"},
    {"max_speed_mps", "number", "0", "speed limit (0: the robot file's)"},
    {"max_turn_rate_dps", "number", "0", "turn rate limit (0: the robot file's)"},
    {"blocked_s", "number", "15", "blocked after this long without progress"},
    {"timeout_s", "number", "600", "give up after this long"},
    {"lost_std_m", "number", "0.5", "lost when the position standard deviation exceeds this"},
    {"lost_unconverged_s", "number", "10",
     "lost when localization has not been converged (scans off the map) for this long"},
    {"obstacle_lookahead_m", "number", "1.5", "look for obstacles this far along the path"},
    {"max_detour_m", "number", "10",
     "a way round what blocks the path may be this much longer than the path left; past that it "
     "waits (a person in a corridor moves on sooner than the robot drives round the building)"},
    {"reapproach_margin_px", "number", "40",
     "re-approaching an aligned target: the stand-off is the nearest from which its content fits "
     "the projector image with this many pixels to spare (more than aim's margin: the base stops "
     "within tolerance_m of its goal, and a pillar's content 10 cm nearer is 60 px taller)"},
    {"reapproach_max_extra_m", "number", "0.5",
     "... searched in 5 cm steps up to this much beyond the target's standoff_m"},
};
const char* const kNavigateOutcomes[] = {"succeeded", "unreachable", "blocked", "timeout", "lost"};

const projtour_param_desc kRelocalizeParams[] = {
    {"widen_m", "number", "1.0", "spread the particle cloud by this much"},
    {"spin_rate_dps", "number", "30", "turn rate while spinning"},
    {"give_up_s", "number", "40", "lost after this long without converging"},
    {"settle_s", "number", "3", "converged for this long before succeeding"},
    {"converged_std_m", "number", "0.15", "converged below this position standard deviation"},
};
const char* const kRelocalizeOutcomes[] = {"succeeded", "lost"};

const projtour_key_desc kNavigateKeys[] = {projtour::reads(keys::kLocalization),
                                           projtour::reads_if_present(keys::kLocalizationConverged),
                                           projtour::reads_if_present(keys::kLaserScan),
                                           projtour::reads_if_present(keys::kAlign),
                                           projtour::reads_if_present(keys::kCapture),
                                           projtour::writes(keys::kNavigate)};
const projtour_key_desc kRelocalizeKeys[] = {projtour::reads(keys::kLocalization),
                                             projtour::reads(keys::kLocalizationConverged),
                                             projtour::writes(keys::kLocalizationWiden)};
const projtour_kind_desc kKinds[] = {
    projtour::with_keys(
        projtour::behaviour_kind<Navigate>(
            "navigate", "plan to the target's stand-off pose on the inflated grid and drive there",
            kNavigateParams, kNavigateOutcomes, projtour::validator<check_navigate_params>()),
        kNavigateKeys),
    projtour::with_keys(
        projtour::behaviour_kind<Relocalize>("relocalize",
                                             "spin in place with a widened "
                                             "particle cloud until localization "
                                             "converges",
                                             kRelocalizeParams, kRelocalizeOutcomes),
        kRelocalizeKeys),
};

}  // namespace
}  // namespace projtour::navigate

PROJTOUR_PLUGIN("navigate", "1.0.0", projtour::navigate::kKinds)
