// The projtour command recording into the history database and `projtour history` summing it
// up: the scripted tour (the testing plugin, null drivers) run, interrupted, resumed, repeated
// in rounds and SIGKILLed at seeded random moments; every output format; bad input.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "projtour/formats/json_io.hpp"
#include "projtour/history/history.hpp"
#include "projtour_test/file_modes.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/run_files.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

const std::string kSource = PROJTOUR_SOURCE_DIR;

std::string read_text(const fs::path& file) {
  return test::read_text_if_exists(file);
}

// One whole-column query's text values, row by row.
std::vector<std::string> query(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  std::vector<std::string> out;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    sqlite3_close(h);
    return {"cannot open"};
  }
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &stmt, nullptr) == SQLITE_OK) {
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      const unsigned char* t = sqlite3_column_text(stmt, 0);
      out.push_back(t == nullptr ? "NULL" : reinterpret_cast<const char*>(t));
    }
  } else {
    out.push_back(std::string("error: ") + sqlite3_errmsg(h));
  }
  sqlite3_finalize(stmt);
  sqlite3_close(h);
  return out;
}

class HistoryCommand : public ::testing::Test {
 protected:
  // The scripted tour with absolute paths; `schedule` (a YAML line) makes it a day of rounds.
  fs::path write_mission(const std::string& schedule = "") {
    std::string text = read_text(kSource + "/missions/scripted_tour.yaml");
    for (std::size_t at = text.find("../"); at != std::string::npos; at = text.find("../", at)) {
      text.replace(at, 3, kSource + "/");
    }
    if (!schedule.empty()) {
      const std::size_t targets = text.find("\ntargets:");
      text.insert(targets + 1, schedule + "\n");
    }
    const fs::path file = dir_ / "mission.yaml";
    std::ofstream(file) << text;
    return file;
  }
  test::ChildOptions command(const std::vector<std::string>& args, const std::string& log) const {
    std::vector<std::string> all = args;
    if (args[0] == "run") {
      for (const char* a : {"--plugin-path", ""}) all.push_back(a);
      all.back() = test::plugin_build_dir().string();
    }
    test::ChildOptions options = test::projtour_command(all);
    options.stdout_file = dir_ / (log + ".stdout");
    options.stderr_file = dir_ / (log + ".stderr");
    return options;
  }
  test::RunResult projtour(const std::vector<std::string>& args, const std::string& log) {
    return test::run(command(args, log), std::chrono::seconds(120));
  }
  // A run of the mission into `out`, paced fast enough to end within a second or two.
  std::vector<std::string> run_args(const fs::path& mission, const fs::path& out) const {
    return {"run",   mission.string(), "--speed",   "200",
            "--out", out.string(),     "--history", db_.string()};
  }

  test::TempDir scratch_;
  const fs::path dir_ = scratch_.path();
  const fs::path db_ = dir_ / "h.sqlite";
};

TEST_F(HistoryCommand, ARunRecordsItsVisitsAndEveryFormatSumsThemUp) {
  const fs::path mission = write_mission();
  const test::RunResult r = projtour(run_args(mission, dir_ / "run"), "run");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(query(db_, "SELECT count(*) FROM visits"), std::vector<std::string>{"3"});
  EXPECT_EQ(query(db_, "SELECT outcome || ' ' || dry_run || ' ' || mission FROM runs"),
            std::vector<std::string>{"completed 0 scripted-tour"});
  EXPECT_EQ(query(db_, "SELECT target FROM visits ORDER BY started_at"),
            (std::vector<std::string>{"rabbit", "pillar", "sign"}));
  EXPECT_EQ(query(db_, "SELECT count(*) FROM visits WHERE ended_at < started_at"),
            std::vector<std::string>{"0"});

  test::RunResult table = projtour({"history", "--history", db_.string()}, "table");
  ASSERT_EQ(table.status, 0) << table.err;
  EXPECT_NE(table.out.find("content.png"), std::string::npos) << table.out;

  test::RunResult csv =
      projtour({"history", "--history", db_.string(), "--csv", "--by", "target"}, "csv");
  ASSERT_EQ(csv.status, 0) << csv.err;
  EXPECT_EQ(csv.out.substr(0, csv.out.find('\n')),
            "key,dry_run,shown_s,showings,visits,blanked_s,median_observed_mm,worst_observed_mm,"
            "median_true_mm,worst_true_mm");
  EXPECT_NE(csv.out.find("\npillar,0,"), std::string::npos) << csv.out;
  EXPECT_NE(csv.out.find("\nsign,0,"), std::string::npos) << csv.out;

  test::RunResult json = projtour({"history", "--history", db_.string(), "--json"}, "json");
  ASSERT_EQ(json.status, 0) << json.err;
  const Json j = parse_json(json.out, "stdout");
  ASSERT_EQ(j.at("rows").size(), 1u);
  EXPECT_EQ(j.at("rows")[0].at("key"), "content.png");
  EXPECT_EQ(j.at("rows")[0].at("showings"), 3);
  EXPECT_EQ(j.at("by"), "content");

  const fs::path page = dir_ / "page.html";
  test::RunResult html =
      projtour({"history", "--history", db_.string(), "--html", page.string()}, "html");
  ASSERT_EQ(html.status, 0) << html.err;
  const std::string text = read_text(page);
  EXPECT_NE(text.find("<tr data-content=\"content.png\">"), std::string::npos) << text;
  EXPECT_NE(text.find("id=\"calendar\""), std::string::npos);

  // A range that holds nothing, and a content that was never shown.
  test::RunResult none = projtour(
      {"history", "--history", db_.string(), "--from", "2001-01-01", "--to", "2001-01-02"}, "none");
  EXPECT_EQ(none.status, 0);
  EXPECT_NE(none.out.find("(no visits in the range)"), std::string::npos) << none.out;
}

// The launcher alone, without the module beside it: `history` still runs (it never loads the
// robot's libraries), every other command names the module it cannot find.
TEST_F(HistoryCommand, TheLauncherAloneRunsHistoryAndNamesTheModuleItLacks) {
  const fs::path mission = write_mission();
  ASSERT_EQ(projtour(run_args(mission, dir_ / "run"), "run").status, 0);
  const fs::path alone = dir_ / "bin" / "projtour";
  fs::create_directories(alone.parent_path());
  fs::copy_file(test::projtour_binary(), alone);

  test::ChildOptions history = command({"history", "--history", db_.string(), "--csv"}, "alone");
  history.argv[0] = alone.string();
  const test::RunResult h = test::run(history, std::chrono::seconds(60));
  ASSERT_EQ(h.status, 0) << h.err;
  EXPECT_NE(h.out.find("\ncontent.png,0,"), std::string::npos) << h.out;

  test::ChildOptions plugins = command({"plugins"}, "alone_plugins");
  plugins.argv[0] = alone.string();
  const test::RunResult p = test::run(plugins, std::chrono::seconds(60));
  EXPECT_EQ(p.status, 1);
  EXPECT_NE(p.err.find("projtour: the projtour installation is incomplete: no command module at " +
                       dir_.string()),
            std::string::npos)
      << p.err;
  // Both places it looks, the build tree's and the installed layout's.
  EXPECT_NE(p.err.find("/projtour/libprojtour_cli.so, " + dir_.string()), std::string::npos)
      << p.err;
}

// Regression: a build-tree launcher looked for the installed layout's module first (by default
// the build directory's parent's lib/projtour/), so another installation's module there, older or
// broken, was loaded instead of the build's own.
TEST_F(HistoryCommand, Regression_ABuildTreeLauncherLoadsItsOwnModuleBeforeAnInstalledOne) {
  const fs::path build = dir_ / "build";
  const fs::path launcher = build / "projtour";
  const fs::path own = build / "lib" / "projtour" / "libprojtour_cli.so";
  const fs::path installed = (build / PROJTOUR_CLI_FROM_INSTALLED_EXE).lexically_normal();
  fs::create_directories(own.parent_path());
  fs::create_directories(installed.parent_path());
  fs::copy_file(test::projtour_binary(), launcher);
  fs::copy_file(test::projtour_binary().parent_path() / "lib" / "projtour" / "libprojtour_cli.so",
                own);
  std::ofstream(installed) << "not a module\n";

  test::ChildOptions help = command({"--help"}, "own_module");
  help.argv[0] = launcher.string();
  const test::RunResult r = test::run(help, std::chrono::seconds(60));
  EXPECT_EQ(r.status, 0) << r.err;
  // The usage, which only the module prints.
  EXPECT_NE(r.err.find("usage:\n  projtour run MISSION.yaml"), std::string::npos) << r.err;

  // With the build's own gone, the one at the installed layout's place is the one tried, and
  // refused by name.
  fs::remove(own);
  const test::RunResult other = test::run(help, std::chrono::seconds(60));
  EXPECT_EQ(other.status, 1);
  EXPECT_NE(other.err.find("projtour: cannot load " + installed.string()), std::string::npos)
      << other.err;
}

TEST_F(HistoryCommand, AMalformedTimeRangeIsExit2NamingTheOption) {
  HistoryDb(db_, HistoryAccess::read_write);
  for (const char* option : {"--from", "--to"}) {
    for (const char* value : {"2026-02-30", "tomorrow", "2026-01-01T10"}) {
      const test::RunResult r =
          projtour({"history", "--history", db_.string(), option, value}, "bad");
      EXPECT_EQ(r.status, 2) << option << " " << value;
      EXPECT_NE(r.err.find(std::string(option) + ": expected YYYY-MM-DD"), std::string::npos)
          << r.err;
    }
  }
  const test::RunResult backwards =
      projtour({"history", "--history", db_.string(), "--from", "2026-03-02", "--to", "2026-03-01"},
               "backwards");
  EXPECT_EQ(backwards.status, 2);
  EXPECT_NE(backwards.err.find("--to: must come after --from"), std::string::npos);
  const test::RunResult by = projtour({"history", "--history", db_.string(), "--by", "week"}, "by");
  EXPECT_EQ(by.status, 2);
  EXPECT_NE(by.err.find("--by"), std::string::npos);
}

TEST_F(HistoryCommand, ABadDatabaseEndsTheRecordingNotTheTour) {
  const fs::path mission = write_mission();
  std::ofstream(db_) << std::string(8192, 'x');  // not a database
  const test::RunResult r = projtour(run_args(mission, dir_ / "run"), "run");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("warning: history: not recorded"), std::string::npos) << r.err;
  const Json report = read_json_file(dir_ / "run" / "report.json");
  ASSERT_TRUE(report.contains("notes")) << report.dump();
  EXPECT_NE(report.at("notes").dump().find("history: not recorded"), std::string::npos);
  EXPECT_EQ(read_text(db_), std::string(8192, 'x'));

  // A newer projtour's file: refused, unchanged, the tour done.
  fs::remove(db_);
  {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db_.c_str(), &h), SQLITE_OK);
    sqlite3_exec(h, "CREATE TABLE later(x); PRAGMA user_version=2", nullptr, nullptr, nullptr);
    sqlite3_close(h);
  }
  const std::string before = read_text(db_);
  const test::RunResult newer = projtour(run_args(mission, dir_ / "run2"), "run2");
  ASSERT_EQ(newer.status, 0) << newer.err;
  EXPECT_NE(newer.err.find("is newer than this projtour knows"), std::string::npos) << newer.err;
  EXPECT_EQ(read_text(db_), before);
}

// A database another writer holds locked for the whole run: the run waits its busy timeout out
// (10 s) at the start, then tours unrecorded, said on stderr and in the report.
TEST_F(HistoryCommand, ALockedDatabaseEndsTheRecordingNotTheTour) {
  const fs::path mission = write_mission();
  { HistoryDb db(db_, HistoryAccess::read_write); }
  sqlite3* holder = nullptr;
  ASSERT_EQ(sqlite3_open(db_.c_str(), &holder), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(holder, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
  const test::RunResult r = projtour(run_args(mission, dir_ / "run"), "run");
  sqlite3_exec(holder, "COMMIT", nullptr, nullptr, nullptr);
  sqlite3_close(holder);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string locked = db_.string() + ": locked by another writer past the busy timeout";
  EXPECT_NE(r.err.find("warning: history: not recorded from here on: " + locked), std::string::npos)
      << r.err;
  const Json report = read_json_file(dir_ / "run" / "report.json");
  EXPECT_NE(report.value("notes", Json::array()).dump().find(locked), std::string::npos)
      << report.dump();
  EXPECT_EQ(query(db_, "SELECT count(*) FROM runs"), std::vector<std::string>{"0"});
}

// Regression: the read-only case was tested only below the command, and skipped as root (CI).
TEST_F(HistoryCommand, AReadOnlyDatabaseEndsTheRecordingNotTheTour) {
  const fs::path mission = write_mission();
  { HistoryDb db(db_, HistoryAccess::read_write); }
  ::chmod(db_.c_str(), 0444);
  test::ChildOptions run = command(run_args(mission, dir_ / "run"), "run");
  std::string why;
  const auto bound = test::with_file_modes_binding(run.argv, why);
  if (!bound) GTEST_SKIP() << why;
  run.argv = *bound;
  const test::RunResult r = test::run(run, std::chrono::seconds(120));
  ::chmod(db_.c_str(), 0644);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string read_only = db_.string() + ": read-only: the run cannot record into it";
  EXPECT_NE(r.err.find("warning: history: not recorded from here on: " + read_only),
            std::string::npos)
      << r.err;
  const Json report = read_json_file(dir_ / "run" / "report.json");
  EXPECT_NE(report.value("notes", Json::array()).dump().find(read_only), std::string::npos)
      << report.dump();
  EXPECT_EQ(query(db_, "SELECT count(*) FROM runs"), std::vector<std::string>{"0"});
}

TEST_F(HistoryCommand, NoHistoryWritesNoneAndTheDefaultFollowsXdgDataHome) {
  const fs::path mission = write_mission();
  test::ChildOptions plain = command(
      {"run", mission.string(), "--speed", "200", "--out", (dir_ / "run").string()}, "default");
  plain.env["XDG_DATA_HOME"] = (dir_ / "xdg").string();
  ASSERT_EQ(test::run(plain).status, 0);
  EXPECT_EQ(query(dir_ / "xdg" / "projtour" / "history.sqlite", "SELECT count(*) FROM visits"),
            std::vector<std::string>{"3"});
  test::ChildOptions none = command({"run", mission.string(), "--speed", "200", "--out",
                                     (dir_ / "run2").string(), "--no-history"},
                                    "none");
  none.env["XDG_DATA_HOME"] = (dir_ / "xdg2").string();
  ASSERT_EQ(test::run(none).status, 0);
  EXPECT_FALSE(fs::exists(dir_ / "xdg2"));
}

TEST_F(HistoryCommand, AResumedVisitIsOneShowingOfOneRun) {
  const fs::path mission = write_mission();
  const fs::path out = dir_ / "run";
  // Interrupted while the pillar is shown: the pillar's visit is cut short and resumed.
  test::ChildOptions first = command(run_args(mission, out), "first");
  first.stop_after_write = "\"state\": \"tour/visit/project\", \"target\": \"pillar\"";
  auto child = std::make_unique<test::Child>(first);
  ASSERT_TRUE(child->wait_stopped(std::chrono::seconds(60))) << child->err();
  child->signal(SIGINT);
  child->resume();
  ASSERT_EQ(child->wait(std::chrono::seconds(60)), 130) << child->err();
  const auto before = query(db_, "SELECT target FROM visits ORDER BY started_at");
  std::vector<std::string> resume = run_args(mission, out);
  resume.push_back("--resume");
  const test::RunResult r = projtour(resume, "resume");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(query(db_, "SELECT count(*) FROM runs"), std::vector<std::string>{"1"});
  EXPECT_EQ(query(db_, "SELECT outcome FROM runs"), std::vector<std::string>{"completed"});
  EXPECT_EQ(query(db_, "SELECT target || ' ' || outcome FROM visits ORDER BY started_at"),
            (std::vector<std::string>{"rabbit projected", "pillar projected", "sign projected"}))
      << "before the resume: " << before.size();
}

TEST_F(HistoryCommand, RoundsAreVisitsOfTheirOwn) {
  const fs::path mission = write_mission("schedule: {rounds: 3, pause_s: 60}");
  const test::RunResult r = projtour(run_args(mission, dir_ / "run"), "run");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(query(db_, "SELECT round || ':' || count(*) FROM visits GROUP BY round ORDER BY round"),
            (std::vector<std::string>{"1:3", "2:3", "3:3"}));
  const test::RunResult s =
      projtour({"history", "--history", db_.string(), "--json", "--by", "target"}, "json");
  ASSERT_EQ(s.status, 0) << s.err;
  const Json j = parse_json(s.out, "stdout");
  ASSERT_EQ(j.at("rows").size(), 3u);
  for (const Json& row : j.at("rows")) EXPECT_EQ(row.at("showings"), 3) << row.dump();
}

// A dry run of the one-target mission: the showing has its proof, the colour camera's view with
// the corners marked as a small JPEG beside the database, whose hash is the row's; the true error
// is recorded beside the observed one, and the run counts only with --include-dry-runs.
TEST_F(HistoryCommand, ADryRunsShowingHasItsProofImage) {
  std::vector<std::string> args = {"run",
                                   kSource + "/missions/minimal.yaml",
                                   "--dry-run",
                                   "--seed",
                                   "1",
                                   "--out",
                                   (dir_ / "run").string(),
                                   "--history",
                                   db_.string()};
  const test::RunResult r = projtour(args, "dry");
  ASSERT_EQ(r.status, 0) << r.err;
  HistoryDb db(db_, HistoryAccess::read_only);
  const auto visits = db.visits();
  ASSERT_EQ(visits.size(), 1u);
  ASSERT_FALSE(visits[0].proof_path.empty());
  EXPECT_TRUE(visits[0].observed_error_mm);
  EXPECT_TRUE(visits[0].true_error_mm);
  const std::string jpeg = read_text(dir_ / visits[0].proof_path);
  ASSERT_GT(jpeg.size(), 1000u);
  EXPECT_EQ(sha256_hex(std::vector<unsigned char>(jpeg.begin(), jpeg.end())),
            visits[0].proof_sha256);
  const cv::Mat image = cv::imread((dir_ / visits[0].proof_path).string());
  EXPECT_EQ(image.cols, 320);
  const test::RunResult real = projtour({"history", "--history", db_.string(), "--json"}, "real");
  EXPECT_EQ(parse_json(real.out, "stdout").at("rows").size(), 0u) << real.out;
  const test::RunResult all =
      projtour({"history", "--history", db_.string(), "--json", "--include-dry-runs"}, "all");
  const Json rows = parse_json(all.out, "stdout").at("rows");
  ASSERT_EQ(rows.size(), 1u) << all.out;
  EXPECT_EQ(rows[0].at("dry_run"), true);
  EXPECT_TRUE(rows[0].at("median_true_mm").is_number());
}

// Regression (a resume after a kill counted five visits of six): the recorder ran after the
// checkpoint's hook, so a kill between the checkpoint and the visit's commit left a visit the
// resume would not do again and the history never held. Stopped as the checkpoint that first
// holds the rabbit is written and killed there, the rabbit is already recorded.
TEST_F(HistoryCommand, KilledAsTheCheckpointIsWrittenTheVisitIsAlreadyRecorded) {
  const fs::path mission = write_mission();
  test::ChildOptions options = command(run_args(mission, dir_ / "run"), "kill");
  options.stop_after_write = "\"id\": \"rabbit\"";
  auto child = std::make_unique<test::Child>(options);
  ASSERT_TRUE(child->wait_stopped(std::chrono::seconds(60))) << child->err();
  EXPECT_EQ(query(db_, "SELECT target || ' ' || outcome FROM visits"),
            std::vector<std::string>{"rabbit projected"});
  child->signal(SIGKILL);
  child->resume();
  child->wait(std::chrono::seconds(30));
  EXPECT_EQ(query(db_, "PRAGMA integrity_check"), std::vector<std::string>{"ok"});
}

// SIGKILL at seeded random moments, every run into one database: after each, the file passes
// integrity_check and every visit row is whole; a resume after the kill counts each visit once.
TEST_F(HistoryCommand, KilledAtRandomMomentsTheDatabaseStaysWhole) {
  const fs::path mission = write_mission("schedule: {rounds: 2}");
  std::mt19937 random(19);
  std::uniform_int_distribution<int> delay_ms(0, 1200);
  int resumed = 0;
  for (int kill = 0; kill < 6; ++kill) {
    const fs::path out = dir_ / ("run" + std::to_string(kill));
    auto child = std::make_unique<test::Child>(command(run_args(mission, out), "kill"));
    // The moment counts from the run's start (its first event), past the loading of plugins.
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!fs::exists(out / "events.jsonl") && std::chrono::steady_clock::now() < limit &&
           !child->poll()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(random)));
    child->signal(SIGKILL);
    child->wait(std::chrono::seconds(30));
    EXPECT_EQ(query(db_, "PRAGMA integrity_check"), std::vector<std::string>{"ok"}) << kill;
    // Killed before the recorder had made its schema (the first run into the file): nothing was
    // recorded, and an empty file is whole.
    if (query(db_, "SELECT count(*) FROM sqlite_master WHERE name = 'visits'") ==
        std::vector<std::string>{"0"}) {
      continue;
    }
    EXPECT_EQ(query(db_,
                    "SELECT count(*) FROM visits v LEFT JOIN runs r ON r.id = v.run_id WHERE "
                    "r.id IS NULL OR v.outcome NOT IN ('projected', 'skipped', 'failed', "
                    "'outside_hours') OR v.ended_at < v.started_at OR v.round NOT IN (1, 2)"),
              std::vector<std::string>{"0"})
        << kill;
    EXPECT_EQ(query(db_,
                    "SELECT count(*) FROM proofs p LEFT JOIN visits v USING (run_id, round, "
                    "target) WHERE v.run_id IS NULL"),
              std::vector<std::string>{"0"});
    // Resumed when the kill left a checkpoint: the run completes, each visit once.
    if (fs::exists(out / "checkpoint.json")) {
      std::vector<std::string> resume = run_args(mission, out);
      resume.push_back("--resume");
      const test::RunResult r = projtour(resume, "resume");
      ASSERT_EQ(r.status, 0) << r.err;
      const std::string dir = fs::weakly_canonical(out).string();
      EXPECT_EQ(query(db_, "SELECT count(*) FROM runs WHERE run_dir = '" + dir + "'"),
                std::vector<std::string>{"1"});
      EXPECT_EQ(query(db_,
                      "SELECT count(*) FROM visits v JOIN runs r ON r.id = v.run_id WHERE "
                      "r.run_dir = '" +
                          dir + "'"),
                std::vector<std::string>{"6"});
      ++resumed;
    }
  }
  EXPECT_GT(resumed, 0) << "no kill came late enough to leave a checkpoint";
}

}  // namespace
}  // namespace projtour
