#include "projtour_executor/target_record.hpp"

#include <stdexcept>

namespace projtour {

namespace {

using namespace json_field;

template <typename T>
void read_optional(const Json& j, const char* key, std::optional<T>& out) {
  const auto it = j.find(key);
  if (it == j.end()) return;
  try {
    out = it->template get<T>();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(key) + ": " + e.what());
  }
}

void read_optional_number(const Json& j, const char* key, std::optional<double>& out) {
  if (j.contains(key)) out = number_at(j, key);
}

}  // namespace

void to_json(Json& j, const AlignFigures& a) {
  j = Json::object();
  j["method"] = a.method;
  j["time_ms"] = a.time_ms;
  j["iterations"] = a.iterations;
  j["inlier_fraction"] = a.inlier_fraction;
  j["rmse_mm"] = a.rmse_mm;
}

void from_json(const Json& j, AlignFigures& a) {
  expect_object(j, "the value");
  reject_unknown(j, {"method", "time_ms", "iterations", "inlier_fraction", "rmse_mm"});
  a.method = string_at(j, "method");
  a.time_ms = number_at(j, "time_ms");
  a.iterations = int_at(j, "iterations");
  a.inlier_fraction = number_at(j, "inlier_fraction");
  a.rmse_mm = number_at(j, "rmse_mm");
}

void to_json(Json& j, const LocalizationError& e) {
  j = Json::object();
  j["trans_m"] = e.trans_m;
  j["rot_deg"] = e.rot_deg;
  if (e.building_trans_m) j["building_trans_m"] = *e.building_trans_m;
  if (e.building_rot_deg) j["building_rot_deg"] = *e.building_rot_deg;
}

void from_json(const Json& j, LocalizationError& e) {
  expect_object(j, "the value");
  reject_unknown(j, {"trans_m", "rot_deg", "building_trans_m", "building_rot_deg"});
  e.trans_m = number_at(j, "trans_m");
  e.rot_deg = number_at(j, "rot_deg");
  if (j.contains("building_trans_m")) e.building_trans_m = number_at(j, "building_trans_m");
  if (j.contains("building_rot_deg")) e.building_rot_deg = number_at(j, "building_rot_deg");
}

void to_json(Json& j, const TargetPoseError& e) {
  j = Json::object();
  j["trans_mm"] = e.trans_mm;
  j["rot_deg"] = e.rot_deg;
}

void from_json(const Json& j, TargetPoseError& e) {
  expect_object(j, "the value");
  reject_unknown(j, {"trans_mm", "rot_deg"});
  e.trans_mm = number_at(j, "trans_mm");
  e.rot_deg = number_at(j, "rot_deg");
}

void to_json(Json& j, const BeforeAfter& e) {
  j = Json::object();
  if (e.before_align) j["before_align"] = *e.before_align;
  if (e.after_align) j["after_align"] = *e.after_align;
}

void from_json(const Json& j, BeforeAfter& e) {
  expect_object(j, "the value");
  reject_unknown(j, {"before_align", "after_align"});
  read_optional_number(j, "before_align", e.before_align);
  read_optional_number(j, "after_align", e.after_align);
}

void to_json(Json& j, const AreaError& e) {
  j = Json::object();
  j["mean"] = e.mean;
  j["max"] = e.max;
}

void from_json(const Json& j, AreaError& e) {
  expect_object(j, "the value");
  reject_unknown(j, {"mean", "max"});
  e.mean = number_at(j, "mean");
  e.max = number_at(j, "max");
}

// time_ms is the wall clock's (decode and fit), like align's.
void to_json(Json& j, const CalibrateResult& c) {
  j = Json::object();
  j["adopted"] = c.adopted;
  j["decoded_blocks"] = c.decoded_blocks;
  j["inliers"] = c.inliers;
  j["rms_px"] = c.rms_px;
  j["change_mm"] = c.change_mm;
  j["change_deg"] = c.change_deg;
  j["sequence_s"] = c.sequence_s;
  j["time_ms"] = c.compute_ms;
}

void from_json(const Json& j, CalibrateResult& c) {
  expect_object(j, "the value");
  reject_unknown(j, {"adopted", "decoded_blocks", "inliers", "rms_px", "change_mm", "change_deg",
                     "sequence_s", "time_ms"});
  // required(), not at(): a missing key must be this file's runtime_error, not nlohmann's.
  const Json& adopted = required(j, "adopted");
  if (!adopted.is_boolean()) throw std::runtime_error("adopted: expected true or false");
  c.adopted = adopted.get<bool>();
  c.decoded_blocks = int_at(j, "decoded_blocks");
  c.inliers = int_at(j, "inliers");
  c.rms_px = number_at(j, "rms_px");
  c.change_mm = number_at(j, "change_mm");
  c.change_deg = number_at(j, "change_deg");
  c.sequence_s = number_at(j, "sequence_s");
  c.compute_ms = number_at(j, "time_ms");
}

void to_json(Json& j, const TargetRecord& r) {
  j = Json::object();
  j["id"] = r.id;
  j["outcome"] = r.outcome;
  if (!r.reason.empty()) j["reason"] = r.reason;
  j["retries"] = r.retries;
  if (r.round > 0) j["round"] = r.round;
  if (!r.content.empty()) {
    j["content"] = r.content;
    j["content_index"] = r.content_index;
  }
  const TargetMeasurements& m = r.measurements;
  if (m.projected_s) j["projected_s"] = *m.projected_s;
  if (m.beam_interruptions) j["beam_interruptions"] = *m.beam_interruptions;
  if (m.blanked_s) j["blanked_s"] = *m.blanked_s;
  if (m.align) j["align"] = *m.align;
  if (m.localization_error) j["localization_error"] = *m.localization_error;
  if (m.target_pose_error) j["target_pose_error"] = *m.target_pose_error;
  if (m.projection_error_mm) j["projection_error_mm"] = *m.projection_error_mm;
  if (m.projection_error_px) j["projection_error_px"] = *m.projection_error_px;
  if (m.observed_error_mm) j["observed_error_mm"] = *m.observed_error_mm;
  if (m.observed_light_on_target) j["observed_light_on_target"] = *m.observed_light_on_target;
  if (m.projection_error_area_mm) j["projection_error_area_mm"] = *m.projection_error_area_mm;
  if (m.light_off_target_fraction) j["light_off_target_fraction"] = *m.light_off_target_fraction;
  if (m.calibration) j["calibration"] = *m.calibration;
}

void from_json(const Json& j, TargetRecord& r) {
  expect_object(j, "a target record");
  reject_unknown(j, {"id",
                     "outcome",
                     "reason",
                     "retries",
                     "round",
                     "content",
                     "content_index",
                     "projected_s",
                     "beam_interruptions",
                     "blanked_s",
                     "align",
                     "localization_error",
                     "target_pose_error",
                     "projection_error_mm",
                     "projection_error_px",
                     "observed_error_mm",
                     "observed_light_on_target",
                     "projection_error_area_mm",
                     "light_off_target_fraction",
                     "calibration"});
  r.id = string_at(j, "id");
  r.outcome = string_at(j, "outcome");
  r.reason = j.contains("reason") ? string_at(j, "reason") : std::string();
  r.retries = int_at(j, "retries");
  r.round = j.contains("round") ? int_at(j, "round") : 0;
  if (j.contains("content")) {
    r.content = string_at(j, "content");
    r.content_index = int_at(j, "content_index");
  }
  TargetMeasurements m;
  read_optional_number(j, "projected_s", m.projected_s);
  if (j.contains("beam_interruptions")) m.beam_interruptions = int_at(j, "beam_interruptions");
  read_optional_number(j, "blanked_s", m.blanked_s);
  read_optional(j, "align", m.align);
  read_optional(j, "localization_error", m.localization_error);
  read_optional(j, "target_pose_error", m.target_pose_error);
  read_optional(j, "projection_error_mm", m.projection_error_mm);
  read_optional(j, "projection_error_px", m.projection_error_px);
  read_optional_number(j, "observed_error_mm", m.observed_error_mm);
  read_optional_number(j, "observed_light_on_target", m.observed_light_on_target);
  read_optional(j, "projection_error_area_mm", m.projection_error_area_mm);
  read_optional_number(j, "light_off_target_fraction", m.light_off_target_fraction);
  read_optional(j, "calibration", m.calibration);
  r.measurements = std::move(m);
}

}  // namespace projtour
