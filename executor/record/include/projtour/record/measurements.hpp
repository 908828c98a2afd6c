#pragma once
// The report's measured fields of a target, from the typed step results a state wrote while it
// ran, whichever kind it is: a NavigateResult gives localization_error, an AlignResult align and
// target_pose_error, a ProjectResult projected_s and projection_error_*. The *_error fields need
// the simulator's ground truth and are left out without it.
#include <cstdint>

#include "projtour/contract/context.hpp"
#include "projtour/record/target_record.hpp"

namespace projtour {

// Adds what the results written after `since_writes` (Blackboard::writes() when the state
// started) let us measure, replacing earlier values of the same visit. Never throws: a failing
// measurement is logged and left out.
void measure_step_results(const Context& ctx, std::uint64_t since_writes,
                          TargetMeasurements& measurements);

}  // namespace projtour
