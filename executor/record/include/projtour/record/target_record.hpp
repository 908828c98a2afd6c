#pragma once
// One target's entry of report.json and checkpoint.json: its outcome and the figures measured
// while it was visited (measurements.hpp), written and read back through to_json/from_json.
// Each type's fields (keys, order, when written, how the summary page shows them) are listed
// once, in record_fields.hpp: a new figure is a member here and a line there.
#include <cstddef>
#include <optional>
#include <string>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/formats/json_io.hpp"

namespace projtour {

// The report's align figures are align's published quality, field for field.
using AlignFigures = AlignQuality;

// The localization estimate against the simulator's true base pose, on the floor plane.
struct LocalizationError {
  // Against where the map draws the place the robot truly stands: the localizer's own error.
  double trans_m = 0.0;
  double rot_deg = 0.0;
  // Against the building, when the map is off the building (a world's map error): the
  // localizer's error plus the map's there.
  std::optional<double> building_trans_m;
  std::optional<double> building_rot_deg;
};

// The aligned camera-to-model pose against the truth.
struct TargetPoseError {
  double trans_mm = 0.0;
  double rot_deg = 0.0;
};

// Mean error of the content corners on the model, from the guess alone and after alignment;
// each is absent when the ground truth could not evaluate it.
struct BeforeAfter {
  std::optional<double> before_align;
  std::optional<double> after_align;
};

// The referee's error over the whole content area (a grid of content points), after alignment.
struct AreaError {
  double mean = 0.0;
  double max = 0.0;
};

// Absent fields were not measured (the *_error ones need the simulator's ground truth).
struct TargetMeasurements {
  std::optional<double> projected_s;
  // The beam guard's figures (project): interruptions and mission seconds blanked.
  std::optional<int> beam_interruptions;
  std::optional<double> blanked_s;
  std::optional<AlignFigures> align;
  std::optional<LocalizationError> localization_error;
  std::optional<TargetPoseError> target_pose_error;
  std::optional<BeforeAfter> projection_error_mm;
  std::optional<BeforeAfter> projection_error_px;
  // The closed loop: the last structured-light calibration of the visit, what the colour camera
  // observed (verify), and the referee's figures over the content area and its light.
  std::optional<CalibrateResult> calibration;
  std::optional<double> observed_error_mm;
  std::optional<double> observed_light_on_target;
  std::optional<AreaError> projection_error_area_mm;
  std::optional<double> light_off_target_fraction;
  // The length of navigate's last plan to the stand-off pose (a replan replaces it): how far
  // the visit's drive was meant to be.
  std::optional<double> planned_path_m;
};

// The outcomes the executor gives a visit (Executor's record_visit), and a target
// passed over in a round because the time of day was outside its hours.
inline constexpr const char* kTargetOutcomes[] = {"projected", "skipped", "failed",
                                                  "outside_hours"};

struct TargetRecord {
  std::size_t index = 0;  // in the mission; not written, the id is
  std::string id;
  std::string outcome;  // projected | skipped | failed | outside_hours
  std::string reason;   // empty when projected
  int retries = 0;
  // The schedule's round (1, 2, ...); 0, and not written, without a schedule.
  int round = 0;
  // The item of a content list this visit showed (its file name and place in the list); empty,
  // and not written, for a target with one content.
  std::string content;
  int content_index = 0;
  TargetMeasurements measurements;
};

// nlohmann's ADL hooks, walking each type's fields as record_fields.hpp defines them. The
// from_json ones are strict: every field of its JSON type, no unknown fields, each error a
// std::runtime_error naming the field.
void to_json(Json& j, const AlignFigures& a);
void from_json(const Json& j, AlignFigures& a);
void to_json(Json& j, const LocalizationError& e);
void from_json(const Json& j, LocalizationError& e);
void to_json(Json& j, const TargetPoseError& e);
void from_json(const Json& j, TargetPoseError& e);
void to_json(Json& j, const BeforeAfter& e);
void from_json(const Json& j, BeforeAfter& e);
void to_json(Json& j, const AreaError& e);
void from_json(const Json& j, AreaError& e);
void to_json(Json& j, const CalibrateResult& c);
void from_json(const Json& j, CalibrateResult& c);
// `index` is not written, and left as it was on reading.
void to_json(Json& j, const TargetRecord& r);
void from_json(const Json& j, TargetRecord& r);

}  // namespace projtour
