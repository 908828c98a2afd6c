// Determinism of a dry run (issue 4, item 8): the same seed gives the same report and events,
// bit for bit apart from the wall-clock fields; another seed gives another run.
#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

// The report without what the wall clock measures: timing.wall_s and every align.time_ms.
Json without_wall_clock(const Json& report) {
  Json out = Json::object();
  for (const auto& [key, value] : report.as_object()) {
    if (key == "timing") {
      Json timing = Json::object();
      for (const auto& [k, v] : value.as_object()) {
        if (k != "wall_s") timing.set(k, v);
      }
      out.set(key, timing);
    } else if (key == "targets") {
      Json targets = Json::array();
      for (const Json& t : value.as_array()) {
        Json target = Json::object();
        for (const auto& [k, v] : t.as_object()) {
          if (k != "align") {
            target.set(k, v);
            continue;
          }
          Json align = Json::object();
          for (const auto& [ak, av] : v.as_object()) {
            if (ak != "time_ms") align.set(ak, av);
          }
          target.set(k, align);
        }
        targets.push_back(target);
      }
      out.set(key, targets);
    } else {
      out.set(key, value);
    }
  }
  return out;
}

using Determinism = DryRunTest;

TEST_F(Determinism, SameSeedSameReportAndEvents) {
  const DryRunResult a = dry_run("nominal_world.yaml", "a", {"--seed", "5"});
  const DryRunResult b = dry_run("nominal_world.yaml", "b", {"--seed", "5"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(a.report.at("seed").as_int(), 5);
  // The wall-clock fields are there (and so really stripped, not absent).
  ASSERT_TRUE(a.report.at("timing").at("wall_s").is_number());
  ASSERT_TRUE(a.report.at("targets").as_array()[0].at("align").at("time_ms").is_number());
  EXPECT_EQ(without_wall_clock(a.report).dump(2), without_wall_clock(b.report).dump(2));
  EXPECT_EQ(read_text(a.dir / "events.jsonl"), read_text(b.dir / "events.jsonl"));
  EXPECT_EQ(read_text(a.dir / "sim_projector_log.jsonl"),
            read_text(b.dir / "sim_projector_log.jsonl"));
  EXPECT_EQ(read_text(a.dir / "checkpoint.json"), read_text(b.dir / "checkpoint.json"));
}

TEST_F(Determinism, TwoSeedsGiveDifferentRuns) {
  const DryRunResult a = dry_run("nominal_world.yaml", "a", {"--seed", "5"});
  const DryRunResult b = dry_run("nominal_world.yaml", "b", {"--seed", "6"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  Json ra = without_wall_clock(a.report);
  Json rb = without_wall_clock(b.report);
  ra.set("seed", Json());
  rb.set("seed", Json());
  EXPECT_NE(ra.dump(2), rb.dump(2));
  // Not just one field: the measured errors of every target differ.
  for (const char* id : {"rabbit", "open-day-sign"}) {
    EXPECT_NE(report_target(a.report, id).at("localization_error").dump(),
              report_target(b.report, id).at("localization_error").dump())
        << id;
    EXPECT_NE(report_target(a.report, id).at("projection_error_mm").dump(),
              report_target(b.report, id).at("projection_error_mm").dump())
        << id;
  }
}

}  // namespace
}  // namespace projtour::integration
