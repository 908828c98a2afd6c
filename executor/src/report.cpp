#include "projtour_executor/report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace projtour {

namespace {

// Round by round (all in round 0 without a schedule), each in mission order.
std::vector<TargetRecord> in_mission_order(std::vector<TargetRecord> records) {
  std::stable_sort(records.begin(), records.end(), [](const auto& a, const auto& b) {
    return a.round != b.round ? a.round < b.round : a.index < b.index;
  });
  return records;
}

std::string cell(std::optional<double> value, int precision) {
  if (!value) return "-";
  std::ostringstream out;
  out << std::fixed << std::setprecision(precision) << *value;
  return out.str();
}

}  // namespace

Json build_report(const RunSummary& summary) {
  Json report = Json::object();
  report["mission"] = summary.mission;
  report["dry_run"] = summary.dry_run;
  report["seed"] = summary.seed;
  report["outcome"] = to_string(summary.outcome);
  if (!summary.reason.empty()) report["reason"] = summary.reason;
  if (!summary.ignored_cancel.empty()) report["ignored_cancel"] = summary.ignored_cancel;
  if (!summary.notes.empty()) report["notes"] = summary.notes;
  Json timing = Json::object();
  timing["wall_s"] = summary.wall_s;
  timing["mission_s"] = summary.mission_s;
  report["timing"] = std::move(timing);
  report["targets"] = in_mission_order(summary.targets);
  if (summary.building) {
    const BuildingTruth& b = *summary.building;
    Json building = Json::object();
    building["people"] = b.people;
    building["unmapped_objects"] = b.unmapped_objects;
    // Infinite when nothing was ever near: JSON has no infinity.
    building["min_clearance_m"] =
        std::isfinite(b.min_clearance_m) ? Json(b.min_clearance_m) : Json();
    building["min_clearance_to"] = b.min_clearance_to;
    building["required_clearance_m"] = b.required_clearance_m;
    building["clearance_violations"] = b.clearance_violations;
    building["lit_on_head_ticks"] = b.lit_on_head_ticks;
    building["lit_on_head_s"] = b.lit_on_head_s;
    building["lit_on_person_ticks"] = b.lit_on_person_ticks;
    building["lit_on_person_s"] = b.lit_on_person_s;
    report["building"] = std::move(building);
  }
  return report;
}

void print_target_table(const RunSummary& summary, std::ostream& out) {
  std::vector<std::string> header = {"target",         "outcome",       "loc err m",   "align ms",
                                     "proj mm before", "proj mm after", "observed mm", "reason"};
  std::vector<std::vector<std::string>> rows;
  const bool rounds = std::any_of(summary.targets.begin(), summary.targets.end(),
                                  [](const TargetRecord& r) { return r.round > 0; });
  for (const auto& r : in_mission_order(summary.targets)) {
    const TargetMeasurements& m = r.measurements;
    std::optional<double> loc_m, align_ms, before_mm, after_mm;
    if (m.localization_error) loc_m = m.localization_error->trans_m;
    if (m.align) align_ms = m.align->time_ms;
    if (m.projection_error_mm) {
      before_mm = m.projection_error_mm->before_align;
      after_mm = m.projection_error_mm->after_align;
    }
    rows.push_back({r.id, r.outcome, cell(loc_m, 3), cell(align_ms, 1), cell(before_mm, 1),
                    cell(after_mm, 1), cell(m.observed_error_mm, 1), r.reason});
    if (rounds) rows.back().insert(rows.back().begin(), std::to_string(r.round));
  }
  if (rounds) header.insert(header.begin(), "round");
  std::vector<std::size_t> width(header.size());
  for (std::size_t c = 0; c < header.size(); ++c) {
    width[c] = header[c].size();
    for (const auto& row : rows) width[c] = std::max(width[c], row[c].size());
  }
  auto print_row = [&](const std::vector<std::string>& row) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      out << std::left << std::setw(static_cast<int>(c + 1 < row.size() ? width[c] + 2 : 0))
          << row[c];
    }
    out << "\n";
  };
  print_row(header);
  for (const auto& row : rows) print_row(row);
}

}  // namespace projtour
