#pragma once
// The report's measured fields of a target, taken when a state running one of the tour's
// behaviour kinds exits: navigate -> localization_error, align -> align and target_pose_error,
// project -> projected_s and projection_error_*. The *_error fields need the simulator's ground
// truth and are left out without it.
#include <string>

#include "projtour/context.hpp"
#include "projtour_executor/target_record.hpp"

namespace projtour {

// Adds what `kind`'s exit lets us measure to `measurements`, replacing earlier values of the
// same visit. Never throws: a failing measurement is logged and left out.
void measure_on_exit(const std::string& kind, const Context& ctx, TargetMeasurements& measurements);

}  // namespace projtour
