#include "projtour_executor/report.hpp"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace projtour {

namespace {

std::vector<TargetRecord> in_mission_order(std::vector<TargetRecord> records) {
  std::stable_sort(records.begin(), records.end(),
                   [](const auto& a, const auto& b) { return a.index < b.index; });
  return records;
}

std::optional<double> number_at(const Json& object, const std::string& key,
                                const std::string& sub) {
  const Json* v = object.find(key);
  if (v == nullptr) return std::nullopt;
  const Json* s = v->find(sub);
  if (s == nullptr || !s->is_number()) return std::nullopt;
  return s->as_double();
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
  report.set("mission", summary.mission);
  report.set("dry_run", summary.dry_run);
  report.set("seed", static_cast<unsigned long long>(summary.seed));
  report.set("outcome", to_string(summary.outcome));
  if (!summary.reason.empty()) report.set("reason", summary.reason);
  if (!summary.ignored_cancel.empty()) {
    Json names = Json::array();
    for (const auto& n : summary.ignored_cancel) names.push_back(Json(n));
    report.set("ignored_cancel", names);
  }
  Json timing = Json::object();
  timing.set("wall_s", summary.wall_s);
  timing.set("mission_s", summary.mission_s);
  report.set("timing", timing);
  Json targets = Json::array();
  for (const auto& r : in_mission_order(summary.targets)) targets.push_back(r.to_json());
  report.set("targets", targets);
  return report;
}

Json checkpoint_to_json(const Checkpoint& checkpoint) {
  Json j = Json::object();
  j.set("mission", checkpoint.mission);
  j.set("seed", static_cast<unsigned long long>(checkpoint.seed));
  j.set("mission_s", checkpoint.mission_s);
  Json done = Json::array();
  for (const auto& r : checkpoint.done) done.push_back(r.to_json());
  j.set("done", done);
  j.set("current_target", checkpoint.current_target ? Json(*checkpoint.current_target) : Json());
  return j;
}

Checkpoint read_checkpoint(const std::filesystem::path& file, const MissionSpec& mission) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot read the checkpoint");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto index_of = [&](const std::string& id) {
    for (std::size_t i = 0; i < mission.targets.size(); ++i) {
      if (mission.targets[i].id == id) return i;
    }
    throw std::runtime_error(file.string() + ": target \"" + id + "\" is not in the mission");
  };
  try {
    const Json j = Json::parse(text);
    Checkpoint c;
    c.mission = j.at("mission").as_string();
    if (c.mission != mission.name) {
      throw std::runtime_error("written by mission \"" + c.mission + "\", not \"" + mission.name +
                               "\"");
    }
    c.seed = static_cast<std::uint64_t>(j.at("seed").as_int());
    c.mission_s = j.at("mission_s").as_double();
    for (const Json& r : j.at("done").as_array()) {
      const std::string id = r.at("id").as_string();
      c.done.push_back(TargetRecord::from_json(r, index_of(id)));
    }
    if (const Json* current = j.find("current_target"); current && !current->is_null()) {
      c.current_target = current->as_string();
      index_of(*c.current_target);
    }
    return c;
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    if (what.rfind(file.string(), 0) == 0) throw;
    throw std::runtime_error(file.string() + ": " + what);
  }
}

void print_target_table(const RunSummary& summary, std::ostream& out) {
  const std::vector<std::string> header = {
      "target", "outcome", "loc err m", "align ms", "proj mm before", "proj mm after", "reason"};
  std::vector<std::vector<std::string>> rows;
  for (const auto& r : in_mission_order(summary.targets)) {
    const Json* align = r.measurements.find("align");
    std::optional<double> align_ms;
    if (align != nullptr) align_ms = align->at("time_ms").as_double();
    rows.push_back({r.id, r.outcome,
                    cell(number_at(r.measurements, "localization_error", "trans_m"), 3),
                    cell(align_ms, 1),
                    cell(number_at(r.measurements, "projection_error_mm", "before_align"), 1),
                    cell(number_at(r.measurements, "projection_error_mm", "after_align"), 1),
                    r.reason.empty() ? "" : r.reason});
  }
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
