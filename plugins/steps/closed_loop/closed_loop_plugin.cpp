// The closed-loop plugin's descriptor: calibrate, verify, and wait (for a beam to clear).
#include <sstream>

#include "calibrate.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "verify.hpp"

namespace projtour::closed_loop {
namespace {

// wait: the projector blank and the head still for duration_s of state time (pauses excluded),
// then succeeded. The default machine waits here for a person to step out of an occluded beam.
class Wait : public Behaviour {
 public:
  Wait(const Params& params, const RunContext&) : duration_s_(params.number(param::kDurationS)) {}
  void start(Context& ctx) override {
    started_s_ = ctx.state_elapsed_s();
    if (ctx.drivers().projector) ctx.drivers().projector->blank();
  }
  std::optional<Outcome> tick(Context& ctx) override {
    if (ctx.cancel_requested()) return Outcome{kOutcomeCancelled, "cancelled while waiting"};
    if (ctx.state_elapsed_s() - started_s_ < duration_s_) return std::nullopt;
    std::ostringstream s;
    s.precision(1);
    s << std::fixed << "waited " << duration_s_ << " s";
    return Outcome{outcome::kSucceeded, s.str()};
  }

 private:
  double duration_s_;
  double started_s_ = 0.0;
};

void check_wait_params(const Params& params) {
  if (!(params.number(param::kDurationS) >= 0))
    throw std::invalid_argument("duration_s: must be >= 0");
}

const projtour_param_desc kCalibrateParams[] = {
    {param::kMaskMarginPx, "integer", "48",
     "the structured light covers the model's projector pixels grown by this much"},
    {param::kRoiMarginPx, "integer", "24",
     "colour pixels decoded: the model's, grown by this much"},
    {param::kFrameTimeoutS, "number", "1.0",
     "no colour frame this long after a show, nor a depth frame with readings for the look before "
     "lighting: no_frame"},
    {param::kMaxChangeMm, "number", "60",
     "a fit moving the content further than this on the target is refused (poor_fit)"},
    {param::kMaxChangeDeg, "number", "5", "... or turning the projector more than this"}};
const char* const kCalibrateOutcomes[] = {
    outcome::kSucceeded, outcome::kOffScreen,   outcome::kTooFewPoints, outcome::kPoorFit,
    outcome::kNoFrame,   outcome::kBlockedBeam, outcome::kOccluded};
const projtour_key_desc kCalibrateKeys[] = {reads(keys::kAlign), reads(keys::kCapture),
                                            reads_if_present(keys::kCalibration),
                                            writes(keys::kCalibration), writes(keys::kCalibrate)};

const projtour_param_desc kVerifyParams[] = {
    {param::kEdgeMarginPx, "number", "8",
     "a Model Point this close to the projector image's edge means off_screen (re-aim)"},
    {param::kDotRadiusPx, "integer", "10", "radius of the dot shown on each Model Point's pixel"},
    {param::kSearchPx, "number", "40",
     "each dot is looked for this far around its expected pixel (at most 0.45 of the distance "
     "between two expected dots)"},
    {param::kMinOnTarget, "number", "0.95",
     "share of the content area's light that must land on the target"},
    {param::kToleranceMm, "number", "-1",
     "largest observed error (mean over the corners) that passes; negative = the target's "
     "tolerance_mm"},
    {param::kFrameTimeoutS, "number", "1.0",
     "no colour frame this long after a show, nor a depth frame with readings for the look before "
     "lighting: no_frame"},
    {param::kOutlineSearchPx, "integer", "80",
     "the target's outline is looked for this far (colour pixels) from where the aligned pose "
     "puts it"},
    {param::kMinOutlineMatched, "number", "0.35",
     "share of the model's outline that must meet an image edge for the outline to count"},
    {param::kClearOutlineMatched, "number", "0.7",
     "an outline matched this well moves the Model Points by whatever slide it sees; a fainter "
     "one only by a gross slide"},
    {param::kSpreadSigmas, "number", "4",
     "uncertain when this many standard deviations of the fit's disagreement with itself at the "
     "Model Points (leaving out each 4 cm block of the model in turn) exceed the tolerance; the "
     "block jackknife under-reads a rough scan, whose errors lean together over more than a "
     "block"},
    {param::kGrossSlideTolerances, "number", "2",
     "a slide of this many tolerances is gross: any counted outline moves the Model Points, and "
     "the pose slides (misaligned) before anything else is judged"}};
const char* const kVerifyOutcomes[] = {
    outcome::kVerified,  outcome::kOutOfTolerance, outcome::kMisaligned,
    outcome::kUncertain, outcome::kOccluded,       outcome::kNotSeen,
    outcome::kOffScreen, outcome::kNoFrame,        outcome::kBlockedBeam};
const projtour_key_desc kVerifyKeys[] = {reads(keys::kAlign), reads(keys::kCapture),
                                         reads_if_present(keys::kCalibration),
                                         writes(keys::kVerify), writes(keys::kAlign)};

const projtour_param_desc kWaitParams[] = {
    {param::kDurationS, "number", "5", "seconds to wait, projector blank"}};
const char* const kWaitOutcomes[] = {outcome::kSucceeded};

const projtour_kind_desc kKinds[] = {
    with_keys(behaviour_kind<Calibrate>(
                  "calibrate",
                  "Gray-code structured light on the target: measures the camera-projector "
                  "calibration with the colour camera and adopts a good fit",
                  kCalibrateParams, kCalibrateOutcomes, validator<check_calibrate_params>()),
              kCalibrateKeys),
    with_keys(
        behaviour_kind<Verify>("verify",
                               "the colour camera checks where the content's corners land "
                               "and that its light lands on the target",
                               kVerifyParams, kVerifyOutcomes, validator<check_verify_params>()),
        kVerifyKeys),
    behaviour_kind<Wait>("wait", "projector blank, head still, for a while", kWaitParams,
                         kWaitOutcomes, validator<check_wait_params>()),
};

}  // namespace
}  // namespace projtour::closed_loop

PROJTOUR_PLUGIN("closed_loop", "1.0.0", projtour::closed_loop::kKinds)
