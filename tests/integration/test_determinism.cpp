// Determinism of a dry run (issue 4, item 8): the same seed gives the same report and events,
// bit for bit apart from the wall-clock fields; another seed gives another run.
#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

// A report or checkpoint without what the wall clock measures: timing.wall_s and every
// align.time_ms and calibration.time_ms (the target records of both).
Json without_wall_clock(const Json& json, const std::string& key = "") {
  if (json.is_array()) {
    Json out = Json::array();
    for (const Json& item : json) out.push_back(without_wall_clock(item));
    return out;
  }
  if (!json.is_object()) return json;
  Json out = Json::object();
  for (const auto& item : json.items()) {
    const std::string& k = item.key();
    if ((key == "timing" && k == "wall_s") ||
        ((key == "align" || key == "calibration") && k == "time_ms")) {
      continue;
    }
    out[k] = without_wall_clock(item.value(), k);
  }
  return out;
}

using Determinism = DryRunTest;

TEST_F(Determinism, SameSeedSameReportAndEvents) {
  const DryRunResult a = dry_run("nominal_world.yaml", "a", {"--seed", "5"});
  const DryRunResult b = dry_run("nominal_world.yaml", "b", {"--seed", "5"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(a.report.at("seed").get<long long>(), 5);
  // Every target was driven to on a plan, whose length the record gives.
  for (const Json& t : a.report.at("targets")) {
    EXPECT_GT(t.at("planned_path_m").get<double>(), 0.0) << dump_json(t);
  }
  // The wall-clock fields are there (and so really stripped, not absent).
  ASSERT_TRUE(a.report.at("timing").at("wall_s").is_number());
  ASSERT_TRUE(a.report.at("targets")[0].at("align").at("time_ms").is_number());
  EXPECT_EQ(dump_json(without_wall_clock(a.report), 2), dump_json(without_wall_clock(b.report), 2));
  EXPECT_EQ(read_text(a.dir / "events.jsonl"), read_text(b.dir / "events.jsonl"));
  EXPECT_EQ(read_text(a.dir / "sim_projector_log.jsonl"),
            read_text(b.dir / "sim_projector_log.jsonl"));
  EXPECT_EQ(dump_json(without_wall_clock(read_json(a.dir / "checkpoint.json")), 2),
            dump_json(without_wall_clock(read_json(b.dir / "checkpoint.json")), 2));
}

TEST_F(Determinism, TwoSeedsGiveDifferentRuns) {
  const DryRunResult a = dry_run("nominal_world.yaml", "a", {"--seed", "5"});
  const DryRunResult b = dry_run("nominal_world.yaml", "b", {"--seed", "6"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  Json ra = without_wall_clock(a.report);
  Json rb = without_wall_clock(b.report);
  ra["seed"] = nullptr;
  rb["seed"] = nullptr;
  EXPECT_NE(dump_json(ra, 2), dump_json(rb, 2));
  // Not just one field: the measured errors of every target differ.
  for (const char* id : {"rabbit", "open-day-sign"}) {
    EXPECT_NE(dump_json(report_target(a.report, id).at("localization_error")),
              dump_json(report_target(b.report, id).at("localization_error")))
        << id;
    EXPECT_NE(dump_json(report_target(a.report, id).at("projection_error_mm")),
              dump_json(report_target(b.report, id).at("projection_error_mm")))
        << id;
  }
}

}  // namespace
}  // namespace projtour::integration
