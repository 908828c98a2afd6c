// All day through the command (README "All day"): a scheduled dry run interrupted by SIGINT
// while projecting in its second round, then resumed with --resume. Over the two runs each
// target of each round is projected exactly once, the round carries through the checkpoint, the
// target outside its hours is passed over with the reason, and the rabbit's content rotates.
#include <signal.h>

#include <map>
#include <utility>

#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

using namespace std::chrono_literals;

class AllDay : public DryRunTest {};

TEST_F(AllDay, InterruptedInTheSecondRoundResumesThatRoundEachTargetOnce) {
  const fs::path mission = data_dir() / "all_day_tour.yaml";
  const fs::path world = data_dir() / "nominal_world.yaml";
  const fs::path run = dir_ / "run";
  {
    test::ChildOptions options =
        test::projtour_command(dry_run_args(mission, world, run), dir_ / "a");
    // Right after the line that enters round 2's projection on the rabbit (the line as
    // events.jsonl writes it).
    options.stop_after_write =
        R"("event": "enter", "state": "tour/visit/project", "target": "rabbit", "round": 2)";
    Child child(options);
    ASSERT_TRUE(child.wait_stopped(120s)) << read_text(dir_ / "a.stderr");
    child.signal(SIGINT);
    child.resume();
    ASSERT_EQ(child.wait(60s), 130) << read_text(dir_ / "a.stderr");
  }
  const Json checkpoint = read_json(run / "checkpoint.json");
  EXPECT_EQ(checkpoint.at("round"), 2);
  EXPECT_EQ(checkpoint.at("current_target"), "rabbit");
  const std::size_t events_before = read_jsonl(run / "events.jsonl").size();
  const std::size_t log_lines_before = read_jsonl(run / "sim_projector_log.jsonl").size();

  const int resumed =
      test::run_projtour(dry_run_args(mission, world, run, {"--resume"}), dir_ / "b", 120s).status;
  ASSERT_EQ(resumed, 0) << read_text(dir_ / "b.stderr");
  const Json report = read_json(run / "report.json");
  EXPECT_EQ(report.at("outcome"), "completed");
  std::vector<std::string> records;
  for (const Json& t : report.at("targets")) {
    records.push_back(std::to_string(t.at("round").get<int>()) + " " +
                      t.at("id").get<std::string>() + " " + t.at("outcome").get<std::string>() +
                      (t.contains("content") ? " " + t.at("content").get<std::string>() : ""));
  }
  EXPECT_EQ(records, (std::vector<std::string>{
                         "1 rabbit projected sale.png", "1 open-day-sign outside_hours",
                         "2 rabbit projected lunch.avi", "2 open-day-sign projected",
                         "3 rabbit projected sale.png", "3 open-day-sign projected"}));
  EXPECT_EQ(report_target(report, "open-day-sign")
                .at("reason")
                .get<std::string>()
                .rfind("outside its hours (12:00-18:00) at 11:59:", 0),
            0u);

  // Each round's projection of each target succeeded once over the two runs: the cut-short one
  // was projected again, nothing done before it was.
  const std::vector<Json> events = read_jsonl(run / "events.jsonl");
  ASSERT_GT(events.size(), events_before);
  std::map<std::pair<int, std::string>, int> projected;
  for (const Json& e : events) {
    if (e.at("event") == "outcome" && e.at("state") == "tour/visit/project" &&
        e.at("outcome") == "succeeded") {
      ++projected[{e.at("round").get<int>(), e.at("target").get<std::string>()}];
    }
  }
  EXPECT_EQ(projected, (std::map<std::pair<int, std::string>, int>{{{1, "rabbit"}, 1},
                                                                   {{2, "rabbit"}, 1},
                                                                   {{2, "open-day-sign"}, 1},
                                                                   {{3, "rabbit"}, 1},
                                                                   {{3, "open-day-sign"}, 1}}));
  const std::vector<Json> resumed_events(events.begin() + events_before, events.end());
  EXPECT_EQ(resumed_events.front().at("round"), 2);
  for (const auto& p : projector_safety_problems(run, resumed_events, log_lines_before)) {
    ADD_FAILURE() << p;
  }
}

}  // namespace
}  // namespace projtour::integration
