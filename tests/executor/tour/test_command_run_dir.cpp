// The projtour command end to end: a run directory belongs to one run (issue 15). A run
// refuses a directory holding another run's or anyone's files, a held lock names its holder,
// planted links are refused rather than written through, and the append-only files never cut
// what they hold. The rest of the command's tests are test_command.cpp's.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

#include "command_fixture.hpp"
#include "projtour/contract/run_files.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/run_files.hpp"

namespace projtour {
namespace {

using command_test::Command;
using command_test::kPluginPath;
using command_test::kSource;
using command_test::read_text;
namespace fs = std::filesystem;
using test::read_jsonl;
// ---- A run directory belongs to one run (issue 15) ----

// Every file under `dir` with its bytes: what "changes nothing" compares.
std::map<std::string, std::string> snapshot_of(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    files[fs::relative(e.path(), dir).string()] =
        e.is_regular_file() ? read_text(e.path()) : std::string("<dir>");
  }
  return files;
}

TEST_F(Command, RunIntoADirectoryHoldingARunExitsTwoAndChangesNothing) {
  const fs::path run = dir_ / "run";
  const std::string mission = kSource + "/missions/scripted_tour.yaml";
  ASSERT_EQ(projtour("run " + mission + " --speed 1000 --out " + run.string()), 0) << err();
  const auto before = snapshot_of(run);
  ASSERT_EQ(projtour("run " + mission + " --speed 1000 --out " + run.string()), 2);
  EXPECT_NE(err().find("projtour: " + run.string() + " already holds files (checkpoint.json, "),
            std::string::npos)
      << err();
  EXPECT_NE(err().find("continue its run with --resume, or choose another --out"),
            std::string::npos);
  EXPECT_EQ(snapshot_of(run), before);
  // A directory of someone else's files is not a run's either, and is left alone.
  const fs::path other = dir_ / "other";
  fs::create_directories(other);
  std::ofstream(other / "notes.txt") << "mine";
  ASSERT_EQ(projtour("run " + mission + " --speed 1000 --out " + other.string()), 2);
  EXPECT_EQ(snapshot_of(other), (std::map<std::string, std::string>{{"notes.txt", "mine"}}));
}

// Regression: two runs without --out started in the same second shared one directory.
TEST_F(Command, DefaultRunDirectoriesAreUniqueForRunsStartedTogether) {
  const std::string line = [&] {
    std::string words;
    for (const std::string& word :
         test::projtour_command(test::shell_words("run " + kSource +
                                                  "/missions/scripted_tour.yaml --speed 1000 "
                                                  "--plugin-path " +
                                                  kPluginPath))
             .argv) {
      words += "'" + word + "' ";
    }
    return words;
  }();
  test::ChildOptions options = command("", "1");
  options.argv = {"/bin/sh", "-c",
                  "cd '" + dir_.string() + "' && { " + line + "& " + line + "& wait; }"};
  EXPECT_EQ(test::run(options).status, 0) << read_text(dir_ / "stderr1.txt");
  std::vector<fs::path> runs;
  for (const auto& e : fs::directory_iterator(dir_ / "runs")) runs.push_back(e.path());
  ASSERT_EQ(runs.size(), 2u);
  for (const fs::path& run : runs) {
    EXPECT_EQ(read_json_file(run / "report.json").at("outcome").get<std::string>(), "completed")
        << run;
    EXPECT_EQ(read_jsonl(run / "events.jsonl").front().at("state").get<std::string>(), "tour");
  }
}

TEST_F(Command, EmptyOutIsAnError) {
  ASSERT_EQ(projtour("run " + kSource + "/missions/scripted_tour.yaml --speed 1000 --out ''"), 2);
  EXPECT_NE(err().find("--out \"\" names no directory"), std::string::npos) << err();
}

// A second run, or a resume, on a directory a run holds exits 2 at once naming the holder.
TEST_F(Command, SecondRunOrResumeOnALockedDirectoryNamesTheHolder) {
  const fs::path run = dir_ / "run";
  const std::string mission = kSource + "/missions/scripted_tour.yaml";
  const auto holder = stopping_after("run " + mission + " --speed 4 --out " + run.string(),
                                     "\"state\": \"tour/visit/aim\"");
  ASSERT_TRUE(holder->wait_stopped(std::chrono::seconds(30))) << holder->err();
  const std::string named = "is in use by another projtour run (pid " +
                            std::to_string(holder->pid()) +
                            "): one run directory, one run at a time";
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(projtour("run " + mission + " --speed 1000 --out " + run.string()), 2);
  EXPECT_NE(err().find(named), std::string::npos) << err();
  EXPECT_EQ(projtour("run " + mission + " --resume --speed 1000 --out " + run.string()), 2);
  EXPECT_NE(err().find(named), std::string::npos) << err();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
            10.0);
  holder->resume();
  EXPECT_EQ(holder->wait(std::chrono::seconds(60)), 0) << holder->err();
  // The holder's events are its own: one tour, entered once.
  std::size_t tours = 0;
  for (const Json& e : read_jsonl(run / "events.jsonl")) {
    tours += e.at("event") == "enter" && e.at("state") == "tour";
  }
  EXPECT_EQ(tours, 1u);
}

// A symbolic link planted in a run directory is an error on resume, never written through.
TEST_F(Command, PlantedSymlinkIsRefusedNotWrittenThrough) {
  const fs::path run = dir_ / "run";
  const std::string mission = kSource + "/missions/scripted_tour.yaml";
  ASSERT_EQ(interrupt_after("run " + mission + " --speed 4 --out " + run.string(),
                            "\"state\": \"tour/visit/aim\", \"target\": \"pillar\""),
            130)
      << read_text(dir_ / "stderr1.txt");
  const fs::path victim = dir_ / "victim.json";
  fs::remove(run / "report.json");
  fs::create_symlink(victim, run / "report.json");
  ASSERT_EQ(projtour("run " + mission + " --resume --speed 1000 --out " + run.string()), 2);
  EXPECT_NE(err().find((run / "report.json").string() + " is a symbolic link"), std::string::npos)
      << err();
  EXPECT_FALSE(fs::exists(victim));
  // The writer refuses one too, should a link appear after the run claimed its directory.
  fs::create_symlink(victim, dir_ / "late.json");
  EXPECT_THROW(write_run_file(dir_ / "late.json", "x"), std::runtime_error);
  EXPECT_THROW(AppendOnlyFile(dir_ / "late.json").append("x"), std::runtime_error);
  EXPECT_FALSE(fs::exists(victim));
}

// Regression: a directory link planted while the run went on (targets/ replaced by a link to
// another directory) was written through, and the run exited 0.
TEST_F(Command, DirectoryLinkPlantedDuringARunIsRefusedAndEndsTheRun) {
  const fs::path run = dir_ / "run";
  const fs::path victim = dir_ / "victim";
  fs::create_directories(victim);
  const auto child = stopping_after(
      "run " + kSource + "/missions/scripted_tour.yaml --speed 4 --out " + run.string(),
      "\"state\": \"tour/visit/aim\"");
  ASSERT_TRUE(child->wait_stopped(std::chrono::seconds(30))) << child->err();
  fs::rename(run / "targets", run / "targets.moved");
  fs::create_directory_symlink(victim, run / "targets");
  child->resume();
  EXPECT_EQ(child->wait(std::chrono::seconds(60)), 1) << child->err();
  EXPECT_TRUE(fs::is_empty(victim));
  const Json report = read_json_file(run / "report.json");
  EXPECT_EQ(report.at("outcome").get<std::string>(), "aborted");
  EXPECT_NE(report.at("reason").get<std::string>().find(
                "refusing to write through the symbolic link " + (run / "targets").string()),
            std::string::npos)
      << dump_json(report, 2);
}

// Regression: deleting .lock let a second run into a directory a run held.
TEST_F(Command, DeletingTheLockFileDoesNotFreeTheDirectory) {
  const fs::path run = dir_ / "run";
  const std::string mission = kSource + "/missions/scripted_tour.yaml";
  const auto holder = stopping_after("run " + mission + " --speed 4 --out " + run.string(),
                                     "\"state\": \"tour/visit/aim\"");
  ASSERT_TRUE(holder->wait_stopped(std::chrono::seconds(30))) << holder->err();
  fs::remove(run / ".lock");
  EXPECT_EQ(projtour("run " + mission + " --resume --speed 1000 --out " + run.string()), 2);
  EXPECT_NE(err().find("is in use by another projtour run (pid unknown)"), std::string::npos)
      << err();
  holder->resume();
  EXPECT_EQ(holder->wait(std::chrono::seconds(60)), 0) << holder->err();
}

// --out may itself be a link to a directory: the user's choice, followed once at the claim.
TEST_F(Command, OutMayBeALinkToADirectory) {
  const fs::path real = dir_ / "real";
  fs::create_directories(real);
  fs::create_directory_symlink(real, dir_ / "link");
  ASSERT_EQ(projtour("run " + kSource + "/missions/scripted_tour.yaml --speed 1000 --out " +
                     (dir_ / "link").string()),
            0)
      << err();
  EXPECT_EQ(read_json_file(real / "report.json").at("outcome").get<std::string>(), "completed");
}

// What a run refused or stopped before its first target leaves (.lock, an empty targets/) is
// no run: a new run may have the directory.
TEST_F(Command, ADirectoryWithOnlyALockAndNoTargetsIsFree) {
  const fs::path run = dir_ / "run";
  fs::create_directories(run / "targets");
  std::ofstream(run / ".lock") << "12345\n";
  EXPECT_EQ(projtour("run " + kSource + "/missions/scripted_tour.yaml --speed 1000 --out " +
                     run.string()),
            0)
      << err();
}

// Every run file beneath a held directory that fails is kept, whoever caught the throw.
TEST_F(Command, HeldRunDirectoryKeepsTheFirstFailureEvenWhenTheWriterOnlyWarned) {
  const fs::path run = dir_ / "run";
  fs::create_directories(run / "targets");
  const fs::path victim = dir_ / "victim";
  fs::create_directories(victim);
  fs::create_directory_symlink(victim, run / "targets" / "sign");
  HeldRunDirectory held(run);
  EXPECT_EQ(held.first_failure(), "");
  write_run_file(run / "report.json", "{}\n");
  make_run_directory(run / "targets" / "pillar" / "deep");
  EXPECT_EQ(held.first_failure(), "");
  try {
    write_run_file(run / "targets" / "sign" / "picture.png", "x");
  } catch (const std::exception&) {
    // a plugin that only warns
  }
  EXPECT_THROW(make_run_directory(run / "targets" / "sign" / "more"), std::runtime_error);
  EXPECT_THROW(AppendOnlyFile(run / "targets" / "sign" / "log.jsonl"), std::runtime_error);
  EXPECT_EQ(held.first_failure(), "refusing to write through the symbolic link " +
                                      (run / "targets" / "sign").string() +
                                      " (a run directory holds only the run's own files)");
  EXPECT_TRUE(fs::is_empty(victim));
}

// Regression: a FIFO planted as a log hung the run; a hard link made its appends land in a
// file outside the run.
TEST_F(Command, AppendOnlyFileRefusesAFifoAndAHardLink) {
  const fs::path fifo = dir_ / "events.jsonl";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_THROW(AppendOnlyFile{fifo}, std::runtime_error);
  const fs::path outside = dir_ / "outside.txt";
  std::ofstream(outside) << "mine\n";
  fs::create_hard_link(outside, dir_ / "log.jsonl");
  try {
    AppendOnlyFile log(dir_ / "log.jsonl");
    ADD_FAILURE() << "a hard-linked log was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("it has another hard link"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(read_text(outside), "mine\n");
}

// Regression: after a full disk cut a line short, a resumed run appended straight after it,
// leaving a line no reader could parse.
TEST_F(Command, AppendOnlyFileCutsAPartialLastLineBeforeContinuing) {
  const fs::path log = dir_ / "log.jsonl";
  std::ofstream(log) << "{\"a\": 1}\n{\"b\": ";
  AppendOnlyFile(log).append("{\"c\": 3}\n");
  EXPECT_EQ(read_text(log), "{\"a\": 1}\n{\"c\": 3}\n");
  std::ofstream(dir_ / "none.jsonl") << "no newline at all";
  AppendOnlyFile(dir_ / "none.jsonl").append("x\n");
  EXPECT_EQ(read_text(dir_ / "none.jsonl"), "x\n");
}

// An append-only log keeps what it holds: a resumed run continues it.
TEST_F(Command, AppendOnlyFileContinuesAndNeverTruncates) {
  const fs::path log = dir_ / "log.jsonl";
  AppendOnlyFile(log).append("one\n");
  AppendOnlyFile(log).append("two\n");
  EXPECT_EQ(read_text(log), "one\ntwo\n");
}

// Regression: every --resume truncated the simulated projector's log.
TEST_F(Command, ResumeAppendsTheSimulatedProjectorLog) {
  const fs::path run = dir_ / "run";
  const std::string mission = kSource + "/missions/minimal.yaml";
  ASSERT_EQ(interrupt_after("run " + mission + " --dry-run --out " + run.string(),
                            "\"state\": \"tour/visit/verify\""),
            130)
      << read_text(dir_ / "stderr1.txt");
  const std::string first = read_text(run / "sim_projector_log.jsonl");
  const std::string first_events = read_text(run / "events.jsonl");
  ASSERT_FALSE(first.empty());
  ASSERT_EQ(projtour("run " + mission + " --dry-run --resume --out " + run.string()), 0) << err();
  const std::string both = read_text(run / "sim_projector_log.jsonl");
  EXPECT_GT(both.size(), first.size());
  EXPECT_EQ(both.substr(0, first.size()), first);
  EXPECT_EQ(read_text(run / "events.jsonl").substr(0, first_events.size()), first_events);
}
}  // namespace
}  // namespace projtour
