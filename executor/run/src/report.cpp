#include "projtour/run/report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "projtour/record/record_fields.hpp"

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

// The number at j[key] (j[key][sub_key] when sub_key is not nullptr), if there is one.
std::optional<double> figure(const Json& j, const char* key, const char* sub_key) {
  const auto it = j.find(key);
  if (it == j.end()) return std::nullopt;
  const Json* v = &*it;
  if (sub_key != nullptr) {
    const auto sub = v->find(sub_key);
    if (sub == v->end()) return std::nullopt;
    v = &*sub;
  }
  if (!v->is_number()) return std::nullopt;
  return v->get<double>();
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
  std::vector<std::string> header = {"target", "outcome"};
  for (const OverviewColumn& c : kOverviewColumns) header.emplace_back(c.terminal_header);
  header.emplace_back("reason");
  std::vector<std::vector<std::string>> rows;
  const bool rounds = std::any_of(summary.targets.begin(), summary.targets.end(),
                                  [](const TargetRecord& r) { return r.round > 0; });
  for (const auto& r : in_mission_order(summary.targets)) {
    // The columns' figures as report.json has them: one definition of where each one is.
    const Json j = r;
    rows.push_back({r.id, r.outcome});
    for (const OverviewColumn& c : kOverviewColumns) {
      rows.back().push_back(cell(figure(j, c.key, c.sub_key), c.precision));
    }
    rows.back().push_back(r.reason);
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
