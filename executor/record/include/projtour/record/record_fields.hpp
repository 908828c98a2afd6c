#pragma once
// The one definition of each result type's fields (target_record.hpp): the JSON key, when the
// field is written, and how the summary page shows it. to_json and the strict from_json
// (target_record.cpp), the summary page's rows (summary_page.cpp) and the report's table
// (report.cpp, kOverviewColumns) all walk these lists, so a figure is added with one line here
// besides its member and its producer. A table of member pointers rather than a visitor
// function: the lists read as the tables they are, are walked the same way for a const record
// (writing), a record being filled (reading) and no record at all (the page, which reads the
// JSON of reports it did not write and must not refuse them).
#include <cstddef>
#include <optional>
#include <tuple>
#include <type_traits>

#include "projtour/record/target_record.hpp"

namespace projtour {

// When a field is written, and so what its absence means when it is read back.
enum class Presence {
  required,        // always written; reading refuses its absence
  optional,        // a std::optional: written when set, unset when absent
  unless_default,  // written when not its type's default (an empty reason, round 0)
  with_previous,   // written, and required, exactly when the field before it was (content_index)
};

// How the summary page shows a field. A top-level field with a label is a row of the target's
// table; a field of a nested type is a part of its parent's row (parts joined by a middle dot).
// A number is `before` + the value times `scale` with `precision` decimals + `unit` (HTML);
// precision kAsText shows the JSON value as text (a string, an integer as written, yes/no).
struct PageFormat {
  static constexpr int kAsText = -1;
  const char* label = nullptr;  // nullptr: not a row of its own (shown in another's, or not)
  bool shown = false;
  int precision = kAsText;
  const char* unit = "";
  const char* before = "";
  double scale = 1.0;
};

// A row of its own (top-level fields) or a part of the parent's row (nested fields).
constexpr PageFormat row(const char* label, int precision = PageFormat::kAsText,
                         const char* unit = "", double scale = 1.0) {
  return PageFormat{label, true, precision, unit, "", scale};
}
constexpr PageFormat part(int precision, const char* unit = "", const char* before = "") {
  return PageFormat{nullptr, true, precision, unit, before, 1.0};
}
// A part named in the rows other fields build from it (BeforeAfter: "before", "after").
constexpr PageFormat named_part(const char* label) {
  return PageFormat{label, true, PageFormat::kAsText, "", "", 1.0};
}
constexpr PageFormat kNotShown{};

template <class Owner, class T>
struct Field {
  const char* key;
  T Owner::*member;
  Presence presence;
  PageFormat page;
};

// A member whose own fields are written in line with its owner's (TargetRecord's measurements).
template <class Owner, class T>
struct InlineFields {
  T Owner::*member;
};

template <class Owner, class T>
constexpr Field<Owner, T> field(const char* key, T Owner::*member, Presence presence,
                                PageFormat page) {
  return Field<Owner, T>{key, member, presence, page};
}

// Fields<T>::kList, in the order they are written and read; kDefined tells a type with fields
// (a nested object) from a plain value.
template <class T>
struct Fields {
  static constexpr bool kDefined = false;
};

template <>
struct Fields<AlignFigures> {
  using A = AlignFigures;
  static constexpr bool kDefined = true;
  static constexpr auto kList = std::make_tuple(
      field("method", &A::method, Presence::required, part(PageFormat::kAsText)),
      field("time_ms", &A::time_ms, Presence::required, part(1, " ms")),
      field("iterations", &A::iterations, Presence::required, part(0, " iterations")),
      field("inlier_fraction", &A::inlier_fraction, Presence::required,
            part(3, "", "inlier fraction ")),
      field("rmse_mm", &A::rmse_mm, Presence::required, part(2, " mm RMSE")));
};

template <>
struct Fields<LocalizationError> {
  using E = LocalizationError;
  static constexpr bool kDefined = true;
  // The building's figures are the referee's (a busy world's map error): not on the page.
  static constexpr auto kList = std::make_tuple(
      field("trans_m", &E::trans_m, Presence::required, part(3, " m")),
      field("rot_deg", &E::rot_deg, Presence::required, part(2, "&deg;")),
      field("building_trans_m", &E::building_trans_m, Presence::optional, kNotShown),
      field("building_rot_deg", &E::building_rot_deg, Presence::optional, kNotShown));
};

template <>
struct Fields<TargetPoseError> {
  using E = TargetPoseError;
  static constexpr bool kDefined = true;
  static constexpr auto kList =
      std::make_tuple(field("trans_mm", &E::trans_mm, Presence::required, part(1, " mm")),
                      field("rot_deg", &E::rot_deg, Presence::required, part(2, "&deg;")));
};

template <>
struct Fields<BeforeAfter> {
  using E = BeforeAfter;
  static constexpr bool kDefined = true;
  static constexpr auto kList = std::make_tuple(
      field("before_align", &E::before_align, Presence::optional, named_part("before")),
      field("after_align", &E::after_align, Presence::optional, named_part("after")));
};

template <>
struct Fields<AreaError> {
  using E = AreaError;
  static constexpr bool kDefined = true;
  static constexpr auto kList =
      std::make_tuple(field("mean", &E::mean, Presence::required, part(1, " mm mean")),
                      field("max", &E::max, Presence::required, part(1, " mm worst")));
};

// time_ms is the wall clock's (decode and fit), like align's.
template <>
struct Fields<CalibrateResult> {
  using C = CalibrateResult;
  static constexpr bool kDefined = true;
  static constexpr auto kList = std::make_tuple(
      field("adopted", &C::adopted, Presence::required, part(PageFormat::kAsText, "", "adopted: ")),
      field("decoded_blocks", &C::decoded_blocks, Presence::required, part(0, " blocks decoded")),
      field("inliers", &C::inliers, Presence::required, part(0, " inliers")),
      field("rms_px", &C::rms_px, Presence::required, part(2, " px RMS")),
      field("change_mm", &C::change_mm, Presence::required, part(1, " mm", "change ")),
      field("change_deg", &C::change_deg, Presence::required, part(2, "&deg;", "change ")),
      field("sequence_s", &C::sequence_s, Presence::required, part(1, " s", "sequence ")),
      field("time_ms", &C::compute_ms, Presence::required, part(1, " ms")));
};

template <>
struct Fields<TargetMeasurements> {
  using M = TargetMeasurements;
  static constexpr bool kDefined = true;
  // beam_interruptions' row shows blanked_s; projection_error_mm's rows show the px figures;
  // observed_error_mm's row the referee's figure beside it (summary_page.cpp).
  static constexpr auto kList = std::make_tuple(
      field("projected_s", &M::projected_s, Presence::optional, row("projected for", 1, " s")),
      field("beam_interruptions", &M::beam_interruptions, Presence::optional, row("beam guard")),
      field("blanked_s", &M::blanked_s, Presence::optional, kNotShown),
      field("align", &M::align, Presence::optional, row("alignment")),
      field("localization_error", &M::localization_error, Presence::optional,
            row("localization error")),
      field("target_pose_error", &M::target_pose_error, Presence::optional,
            row("target pose error")),
      field("projection_error_mm", &M::projection_error_mm, Presence::optional,
            row("projection error")),
      field("projection_error_px", &M::projection_error_px, Presence::optional, kNotShown),
      field("observed_error_mm", &M::observed_error_mm, Presence::optional,
            row("observed error (colour camera)", 1, " mm")),
      field("observed_light_on_target", &M::observed_light_on_target, Presence::optional,
            row("light on the target (observed)", 1, " %", 100.0)),
      field("projection_error_area_mm", &M::projection_error_area_mm, Presence::optional,
            row("projection error over the content area")),
      field("light_off_target_fraction", &M::light_off_target_fraction, Presence::optional,
            row("light off the target (referee)", 1, " %", 100.0)),
      field("calibration", &M::calibration, Presence::optional, row("projector calibration")),
      field("planned_path_m", &M::planned_path_m, Presence::optional,
            row("planned path", 1, " m")));
};

// The target's own fields, then its measurements' in line (one JSON object per target). The
// id is the section's heading on the page; `index` is not written (the id is).
template <>
struct Fields<TargetRecord> {
  using R = TargetRecord;
  static constexpr bool kDefined = true;
  static constexpr auto kList = std::make_tuple(
      field("id", &R::id, Presence::required, kNotShown),
      field("outcome", &R::outcome, Presence::required, row("outcome")),
      field("reason", &R::reason, Presence::unless_default, row("reason")),
      field("retries", &R::retries, Presence::required, row("retries")),
      field("round", &R::round, Presence::unless_default, row("round")),
      field("content", &R::content, Presence::unless_default, row("content")),
      field("content_index", &R::content_index, Presence::with_previous, row("content index")),
      InlineFields<R, TargetMeasurements>{&R::measurements});
};

template <class E>
struct IsInline : std::false_type {};
template <class Owner, class T>
struct IsInline<InlineFields<Owner, T>> : std::true_type {};

template <class T, class E, class F>
void visit_entry(T& object, const E& entry, F& f);

// Calls f(field, owner) for each Field of `object`'s type, in order, where owner is `object`
// or, for the fields of an InlineFields member, that member. `object` may be const (writing,
// or a default instance for the field list alone) or not (reading).
template <class T, class F>
void for_each_field(T& object, F&& f) {
  std::apply([&](const auto&... entry) { (visit_entry(object, entry, f), ...); },
             Fields<std::remove_const_t<T>>::kList);
}

template <class T, class E, class F>
void visit_entry(T& object, const E& entry, F& f) {
  if constexpr (IsInline<E>::value) {
    for_each_field(object.*entry.member, f);
  } else {
    f(entry, object);
  }
}

// The value type a field holds: T of std::optional<T>, else itself.
template <class T>
struct FieldValue {
  using type = T;
};
template <class T>
struct FieldValue<std::optional<T>> {
  using type = T;
};
template <class T>
using field_value_t = typename FieldValue<T>::type;

// A column of the overview table, the same figure in the terminal's table at the end of a run
// (report.cpp) and in the summary page's table of targets: the figure at key (sub_key within a
// nested type when not nullptr), shown with `precision` decimals, "-" when absent.
struct OverviewColumn {
  const char* terminal_header;
  const char* page_header;
  const char* key;
  const char* sub_key;
  int precision;
};

inline constexpr OverviewColumn kOverviewColumns[] = {
    {"loc err m", "localization error m", "localization_error", "trans_m", 3},
    {"align ms", "align ms", "align", "time_ms", 1},
    {"proj mm before", "projection error before mm", "projection_error_mm", "before_align", 1},
    {"proj mm after", "projection error after mm", "projection_error_mm", "after_align", 1},
    {"observed mm", "observed error mm", "observed_error_mm", nullptr, 1}};

}  // namespace projtour
