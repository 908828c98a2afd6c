// Plugin `navigate`: behaviours navigate and relocalize.
#include "navigate.hpp"

#include <stdexcept>
#include <string>

#include "projtour/contract/plugin_author.hpp"

namespace projtour::navigate {
namespace {

void check_navigate_params(const Params& p) {
  for (const char* name :
       {param::kToleranceM, param::kToleranceDeg, param::kLookaheadM, param::kBlockedS,
        param::kTimeoutS, param::kLostStdM, param::kLostUnconvergedS, param::kObstacleLookaheadM,
        param::kMaxDetourM}) {
    if (!(p.number(name) > 0.0)) {
      throw std::invalid_argument(std::string(name) + ": expected a positive number");
    }
  }
  if (!(p.number(param::kReapproachMarginPx) >= 0.0)) {
    throw std::invalid_argument("reapproach_margin_px: expected a number >= 0");
  }
  if (!(p.number(param::kReapproachMaxExtraM) >= 0.0 &&
        p.number(param::kReapproachMaxExtraM) <= 3.0)) {
    throw std::invalid_argument("reapproach_max_extra_m: expected a number in [0, 3]");
  }
}

const projtour_param_desc kNavigateParams[] = {
    {param::kToleranceM, "number", "0.10", "succeed when the estimate is this close to the goal"},
    {param::kToleranceDeg, "number", "5", "and its heading this close"},
    {param::kLookaheadM, "number", "0.6", "pure pursuit lookahead distance"},
    {param::kMaxSpeedMps, "number", "0", "speed limit (0: the robot file's)"},
    {param::kMaxTurnRateDps, "number", "0", "turn rate limit (0: the robot file's)"},
    {param::kBlockedS, "number", "15", "blocked after this long without progress"},
    {param::kTimeoutS, "number", "600", "give up after this long"},
    {param::kLostStdM, "number", "0.5", "lost when the position standard deviation exceeds this"},
    {param::kLostUnconvergedS, "number", "10",
     "lost when localization has not been converged (scans off the map) for this long"},
    {param::kObstacleLookaheadM, "number", "1.5", "look for obstacles this far along the path"},
    {param::kMaxDetourM, "number", "10",
     "a way round what blocks the path may be this much longer than the path left; past that it "
     "waits (a person in a corridor moves on sooner than the robot drives round the building)"},
    {param::kReapproachMarginPx, "number", "40",
     "re-approaching an aligned target: the stand-off is the nearest from which its content fits "
     "the projector image with this many pixels to spare (more than aim's margin: the base stops "
     "within tolerance_m of its goal, and a pillar's content 10 cm nearer is 60 px taller)"},
    {param::kReapproachMaxExtraM, "number", "0.5",
     "... searched in 5 cm steps up to this much beyond the target's standoff_m"},
};
const char* const kNavigateOutcomes[] = {outcome::kSucceeded, outcome::kUnreachable,
                                         outcome::kBlocked, outcome::kTimeout, outcome::kLost};

const projtour_param_desc kRelocalizeParams[] = {
    {param::kWidenM, "number", "1.0", "spread the particle cloud by this much"},
    {param::kSpinRateDps, "number", "30", "turn rate while spinning"},
    {param::kGiveUpS, "number", "40", "lost after this long without converging"},
    {param::kSettleS, "number", "3", "converged for this long before succeeding"},
    {param::kConvergedStdM, "number", "0.15", "converged below this position standard deviation"},
};
const char* const kRelocalizeOutcomes[] = {outcome::kSucceeded, outcome::kLost};

const projtour_key_desc kNavigateKeys[] = {
    projtour::reads(keys::kLocalization), projtour::reads_if_present(keys::kLocalizationConverged),
    projtour::reads_if_present(keys::kLaserScan), projtour::reads_if_present(keys::kAlign),
    projtour::reads_if_present(keys::kCapture),
    // aim's reapproach: the stand-off fits the content through the
    // calibration believed now (navigate.cpp's start)
    projtour::reads_if_present(keys::kCalibration), projtour::writes(keys::kNavigate)};
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
