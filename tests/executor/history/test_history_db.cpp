// The history database layer (history.hpp): schema, migration, refusals, concurrent writers,
// visits counted once, the time options and the summaries.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "projtour/history/history.hpp"
#include "projtour_test/chromium.hpp"
#include "projtour_test/file_modes.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `sql` on the file with SQLite itself, outside HistoryDb.
void raw_exec(const fs::path& file, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  const std::string what = message != nullptr ? message : "";
  sqlite3_free(message);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << what;
}

HistoryRun a_run(const std::string& id, bool dry = true) {
  HistoryRun r;
  r.id = id;
  r.mission = "m";
  r.robot = "ud";
  r.run_dir = "/runs/" + id;
  r.started_at_s = 1.7e9;
  r.dry_run = dry;
  r.seed = 7;
  return r;
}

HistoryVisit a_visit(const std::string& run, int round, const std::string& target,
                     const std::string& content, double at_s, double observed_mm = 1.0) {
  HistoryVisit v;
  v.run_id = run;
  v.round = round;
  v.target = target;
  v.content = content;
  v.started_at_s = at_s;
  v.ended_at_s = at_s + 20.0;
  v.shown_s = 10.0;
  v.blanked_s = 1.5;
  v.observed_error_mm = observed_mm;
  v.true_error_mm = 0.5 * observed_mm;
  v.outcome = "projected";
  return v;
}

TEST(HistoryDb, CreatesTheSchemaAtTheCurrentVersionInWalMode) {
  test::TempDir dir;
  const fs::path file = dir.path() / "sub" / "h.sqlite";
  {
    HistoryDb db(file, HistoryAccess::read_write);
    EXPECT_EQ(db.schema_version(), kHistorySchemaVersion);
  }
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &raw), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(raw, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0)), "wal");
  sqlite3_finalize(stmt);
  sqlite3_close(raw);
}

TEST(HistoryDb, MigratesAnEmptyFileAndOpensAVersion1FileAsItIs) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  // Version 0: a file SQLite made with nothing in it.
  raw_exec(file, "PRAGMA user_version=0");
  {
    HistoryDb db(file, HistoryAccess::read_write);
    EXPECT_EQ(db.schema_version(), 1);
    db.upsert_run(a_run("r1"));
    db.record_visit(a_visit("r1", 0, "t", "c.png", 1.7e9));
  }
  // Opened again at v1: nothing is migrated twice, the rows are there.
  HistoryDb again(file, HistoryAccess::read_write);
  EXPECT_EQ(again.schema_version(), 1);
  ASSERT_EQ(again.visits().size(), 1u);
  EXPECT_EQ(again.visits()[0].content, "c.png");
}

TEST(HistoryDb, RefusesANewerVersionAndLeavesTheFileByteForByte) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  raw_exec(file, "CREATE TABLE future(x); PRAGMA user_version=99");
  const std::string before = bytes_of(file);
  for (const HistoryAccess access : {HistoryAccess::read_write, HistoryAccess::read_only}) {
    try {
      HistoryDb db(file, access);
      FAIL() << "a version 99 file was opened";
    } catch (const HistoryError& e) {
      EXPECT_NE(std::string(e.what()).find("version 99 is newer"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(bytes_of(file), before);
}

TEST(HistoryDb, ACorruptFileIsAnErrorNamingIt) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  std::ofstream(file) << std::string(8192, 'x');
  try {
    HistoryDb db(file, HistoryAccess::read_write);
    FAIL() << "a file of x's was opened";
  } catch (const HistoryError& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

// Runs `check` in a forked child whose file modes bind (root's overrides given up) and returns
// its exit status: 0 when it held, kCannotDrop when this machine cannot drop them, else the
// failing step (what failed is on stderr).
constexpr int kCannotDrop = 77;
template <class Check>
int in_child_bound_by_file_modes(Check check) {
  const pid_t child = ::fork();
  if (child == 0) {
    int status = kCannotDrop;
    if (test::give_up_file_mode_override()) {
      try {
        status = check();
      } catch (const std::exception& e) {
        std::cerr << "unexpected: " << e.what() << "\n";
        status = 99;
      }
    }
    std::cerr.flush();
    ::_exit(status);
  }
  int status = 0;
  if (child < 0 || ::waitpid(child, &status, 0) != child) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Regression: this test skipped as root, CI's user, so it had never run there.
TEST(HistoryDb, AReadOnlyFileCannotBeRecordedIntoButCanBeRead) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  {
    HistoryDb db(file, HistoryAccess::read_write);
    db.upsert_run(a_run("r1"));
  }
  ::chmod(file.c_str(), 0444);
  const std::string before = bytes_of(file);
  const int status = in_child_bound_by_file_modes([&] {
    try {
      HistoryDb db(file, HistoryAccess::read_write);
      std::cerr << "a read-only file was opened to record into\n";
      return 1;
    } catch (const HistoryError& e) {
      const std::string what = e.what();
      if (what.find(file.string() + ": read-only") == std::string::npos) {
        std::cerr << "not named read-only: " << what << "\n";
        return 2;
      }
    }
    HistoryDb db(file, HistoryAccess::read_only);
    return db.runs().size() == 1 ? 0 : 3;
  });
  ::chmod(file.c_str(), 0644);
  if (status == kCannotDrop) GTEST_SKIP() << "root's file-mode override cannot be dropped here";
  EXPECT_EQ(status, 0);
  EXPECT_EQ(bytes_of(file), before);
}

TEST(HistoryDb, AnUnreadableFileIsAnErrorNamingIt) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  {
    HistoryDb db(file, HistoryAccess::read_write);
    db.upsert_run(a_run("r1"));
  }
  ::chmod(file.c_str(), 0);
  const int status = in_child_bound_by_file_modes([&] {
    for (const HistoryAccess access : {HistoryAccess::read_write, HistoryAccess::read_only}) {
      try {
        HistoryDb db(file, access);
        std::cerr << "an unreadable file was opened\n";
        return 1;
      } catch (const HistoryError& e) {
        if (std::string(e.what()).find(file.string() + ": cannot open") == std::string::npos) {
          std::cerr << "not named: " << e.what() << "\n";
          return 2;
        }
      }
    }
    return 0;
  });
  ::chmod(file.c_str(), 0644);
  if (status == kCannotDrop) GTEST_SKIP() << "root's file-mode override cannot be dropped here";
  EXPECT_EQ(status, 0);
}

// Another writer holding the lock past the busy timeout: the visit is an error naming the file
// and the lock, after waiting the timeout out; once the lock is let go, recording goes on.
TEST(HistoryDb, ALockedDatabaseWaitsItsBusyTimeoutThenIsAnErrorNamingIt) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  constexpr int kBusyTimeoutMs = 300;
  HistoryDb db(file, HistoryAccess::read_write, kBusyTimeoutMs);
  db.upsert_run(a_run("r1"));
  sqlite3* holder = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &holder), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(holder, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
  const auto before = std::chrono::steady_clock::now();
  try {
    db.record_visit(a_visit("r1", 0, "pillar", "a.png", 1.7e9));
    ADD_FAILURE() << "recorded through another writer's lock";
  } catch (const HistoryError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string() + ": locked by another writer past the "
                                                         "busy timeout"),
              std::string::npos)
        << e.what();
  }
  EXPECT_GE(std::chrono::steady_clock::now() - before, std::chrono::milliseconds(kBusyTimeoutMs));
  ASSERT_EQ(sqlite3_exec(holder, "COMMIT", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(holder);
  db.record_visit(a_visit("r1", 0, "pillar", "a.png", 1.7e9));
  EXPECT_EQ(db.visits().size(), 1u);
}

TEST(HistoryDb, AReadOnlyOpenWritesNothing) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  {
    HistoryDb db(file, HistoryAccess::read_write);
    db.upsert_run(a_run("r1"));
  }
  const std::string before = bytes_of(file);
  HistoryDb db(file, HistoryAccess::read_only);
  EXPECT_EQ(db.runs().size(), 1u);
  EXPECT_THROW(db.upsert_run(a_run("r2")), HistoryError);
  EXPECT_EQ(bytes_of(file), before);
}

TEST(HistoryDb, AVisitRecordedTwiceIsOneShowing) {
  test::TempDir dir;
  HistoryDb db(dir.path() / "h.sqlite", HistoryAccess::read_write);
  db.upsert_run(a_run("r1"));
  db.record_visit(a_visit("r1", 2, "pillar", "a.png", 1.7e9, 1.0));
  // The same visit again (resumed, retried): it replaces the first.
  db.record_visit(a_visit("r1", 2, "pillar", "a.png", 1.7e9 + 5, 2.0));
  db.record_visit(a_visit("r1", 3, "pillar", "a.png", 1.7e9 + 900, 3.0));
  const auto visits = db.visits();
  ASSERT_EQ(visits.size(), 2u);
  EXPECT_EQ(visits[0].round, 2);
  EXPECT_DOUBLE_EQ(*visits[0].observed_error_mm, 2.0);
  EXPECT_EQ(visits[1].round, 3);
  ASSERT_EQ(db.runs().size(), 1u);
  EXPECT_DOUBLE_EQ(*db.runs()[0].ended_at_s, 1.7e9 + 920);
}

TEST(HistoryDb, ProofsAreStoredBesideTheDatabaseByTheirHash) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  HistoryDb db(file, HistoryAccess::read_write);
  db.upsert_run(a_run("r1"));
  const std::vector<unsigned char> jpeg = {0xff, 0xd8, 0xff, 0xe0, 1, 2, 3};
  const StoredProof proof = store_proof(file, jpeg);
  // The SHA-256 of those bytes, from `sha256sum`.
  EXPECT_EQ(proof.sha256, sha256_hex(jpeg));
  EXPECT_EQ(sha256_hex({'a', 'b', 'c'}),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(bytes_of(dir.path() / proof.relative_path), std::string(jpeg.begin(), jpeg.end()));
  HistoryVisit v = a_visit("r1", 0, "t", "c.png", 1.7e9);
  v.proof_path = proof.relative_path;
  v.proof_sha256 = proof.sha256;
  db.record_visit(v);
  EXPECT_EQ(db.visits()[0].proof_sha256, proof.sha256);
}

// Two processes recording into one new file at once: both wait on SQLite's lock, and every row
// of both is there.
TEST(HistoryDb, TwoWritersInTwoProcessesBothComplete) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  constexpr int kVisits = 200;
  pid_t children[2];
  for (int c = 0; c < 2; ++c) {
    children[c] = ::fork();
    ASSERT_GE(children[c], 0);
    if (children[c] == 0) {
      int status = 0;
      try {
        HistoryDb db(file, HistoryAccess::read_write);
        const std::string id = "writer" + std::to_string(c);
        db.upsert_run(a_run(id));
        for (int i = 0; i < kVisits; ++i) {
          db.record_visit(a_visit(id, i, "t", "c.png", 1.7e9 + i));
        }
      } catch (...) {
        status = 1;
      }
      ::_exit(status);
    }
  }
  for (const pid_t child : children) {
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  }
  HistoryDb db(file, HistoryAccess::read_only);
  EXPECT_EQ(db.visits().size(), 2u * kVisits);
  EXPECT_EQ(db.runs().size(), 2u);
}

TEST(HistoryDb, SummariesByContentTargetDayAndRunKeepDryRunsApart) {
  test::TempDir dir;
  HistoryDb db(dir.path() / "h.sqlite", HistoryAccess::read_write);
  db.upsert_run(a_run("dry", true));
  db.upsert_run(a_run("real", false));
  const double day1 = *parse_history_time("2026-03-02");
  db.record_visit(a_visit("real", 0, "pillar", "sale.png", day1 + 3600, 1.0));
  db.record_visit(a_visit("real", 0, "sign", "sale.png", day1 + 7200, 3.0));
  db.record_visit(a_visit("real", 1, "sign", "sale.png", day1 + 86400 + 60, 2.0));
  HistoryVisit skipped = a_visit("real", 1, "pillar", "menu.png", day1 + 86400 + 90);
  skipped.outcome = "skipped";
  skipped.shown_s = 0.0;
  db.record_visit(skipped);
  db.record_visit(a_visit("dry", 0, "pillar", "sale.png", day1 + 100, 9.0));

  HistoryQuery q;
  auto rows = summarize_history(db, q);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].key, "menu.png");
  EXPECT_EQ(rows[0].showings, 0);
  EXPECT_EQ(rows[0].visits, 1);
  EXPECT_EQ(rows[1].key, "sale.png");
  EXPECT_EQ(rows[1].showings, 3);
  EXPECT_DOUBLE_EQ(rows[1].shown_s, 30.0);
  EXPECT_DOUBLE_EQ(rows[1].blanked_s, 4.5);
  EXPECT_DOUBLE_EQ(*rows[1].median_observed_mm, 2.0);
  EXPECT_DOUBLE_EQ(*rows[1].worst_observed_mm, 3.0);
  EXPECT_FALSE(rows[1].dry_run);

  q.include_dry_runs = true;
  rows = summarize_history(db, q);
  ASSERT_EQ(rows.size(), 3u);  // the dry run's sale.png is a row of its own
  EXPECT_TRUE(rows[2].dry_run);
  EXPECT_DOUBLE_EQ(*rows[2].worst_observed_mm, 9.0);
  EXPECT_DOUBLE_EQ(*rows[2].worst_true_mm, 4.5);

  q = HistoryQuery{};
  q.by = "day";
  rows = summarize_history(db, q);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].key, "2026-03-02");
  EXPECT_EQ(rows[0].showings, 2);
  EXPECT_EQ(rows[1].key, "2026-03-03");

  q.by = "target";
  q.from_s = day1 + 86400;
  rows = summarize_history(db, q);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].key, "pillar");
  EXPECT_EQ(rows[1].key, "sign");
  EXPECT_EQ(rows[1].showings, 1);

  q = HistoryQuery{};
  q.by = "run";
  q.content = "sale.png";
  q.target = "sign";
  rows = summarize_history(db, q);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].key, "real");
  EXPECT_EQ(rows[0].showings, 2);
}

TEST(HistoryTime, DatesAndDateTimesInUtcAndNothingElse) {
  bool date_only = false;
  EXPECT_EQ(parse_history_time("1970-01-02", &date_only), 86400.0);
  EXPECT_TRUE(date_only);
  EXPECT_EQ(parse_history_time("1970-01-01T01:00", &date_only), 3600.0);
  EXPECT_FALSE(date_only);
  EXPECT_EQ(parse_history_time("1970-01-01T01:00:30Z"), 3630.0);
  for (const char* bad :
       {"", "2026", "2026-13-01", "2026-02-30", "2026-1-01", "2026-01-01 10:00", "2026-01-01T25:00",
        "2026-01-01T10:00:00+01:00", "yesterday", "2026-01-01T10:00:0"}) {
    EXPECT_FALSE(parse_history_time(bad)) << bad;
  }
}

TEST(HistoryDefaultPath, FollowsXdgDataHomeElseHome) {
  const char* xdg = std::getenv("XDG_DATA_HOME");
  const std::string saved_xdg = xdg != nullptr ? xdg : "";
  const char* home = std::getenv("HOME");
  const std::string saved_home = home != nullptr ? home : "";
  ::setenv("XDG_DATA_HOME", "/data/x", 1);
  EXPECT_EQ(default_history_path(), fs::path("/data/x/projtour/history.sqlite"));
  ::setenv("XDG_DATA_HOME", "relative", 1);  // invalid by the spec: ignored
  ::setenv("HOME", "/home/u", 1);
  EXPECT_EQ(default_history_path(), fs::path("/home/u/.local/share/projtour/history.sqlite"));
  if (home != nullptr) {
    ::setenv("HOME", saved_home.c_str(), 1);
  } else {
    ::unsetenv("HOME");
  }
  if (xdg != nullptr) {
    ::setenv("XDG_DATA_HOME", saved_xdg.c_str(), 1);
  } else {
    ::unsetenv("XDG_DATA_HOME");
  }
}

using test::chromium_command;
using test::dom_in_chromium;

TEST(HistoryPage, ProofImagesLoadAndTotalsShowInHeadlessChromium) {
  if (chromium_command().empty()) {
    GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  }
  test::TempDir dir;
  const fs::path file = dir.path() / "db" / "h.sqlite";
  HistoryDb db(file, HistoryAccess::read_write);
  db.upsert_run(a_run("real", false));
  const double day = *parse_history_time("2026-03-02");
  for (int i = 0; i < 3; ++i) {
    cv::Mat image(240, 320, CV_8UC3, cv::Scalar(40 * i, 90, 200));
    std::vector<unsigned char> jpeg;
    cv::imencode(".jpg", image, jpeg);
    const StoredProof proof = store_proof(file, jpeg);
    HistoryVisit v = a_visit("real", i + 1, "pillar", i == 2 ? "menu.png" : "sale.png",
                             day + 3600 * (i + 1) + 86400 * (i / 2));
    v.proof_path = proof.relative_path;
    v.proof_sha256 = proof.sha256;
    db.record_visit(v);
  }
  // The page elsewhere than the database: the images are found from the page's directory.
  const fs::path page = dir.path() / "pages" / "history.html";
  fs::create_directories(page.parent_path());
  write_history_page(db, HistoryQuery{}, page);
  const std::string dom = dom_in_chromium(page, dir.path());
  int loaded = 0, images = 0;
  for (const test::LoadedImage& image : test::images_of(dom)) {
    ++images;
    if (image.loaded == "1") ++loaded;
  }
  EXPECT_EQ(images, 3) << dom;
  EXPECT_EQ(loaded, 3) << dom;
  // The totals: sale.png twice, 20 s; menu.png once, 10 s.
  EXPECT_NE(dom.find("<td class=\"shown\">20.0</td><td class=\"showings\">2</td>"),
            std::string::npos)
      << dom;
  EXPECT_NE(dom.find("<td class=\"shown\">10.0</td><td class=\"showings\">1</td>"),
            std::string::npos);
  // A proof gone from the disk shows as not loaded.
  fs::remove_all(proofs_dir_of(file));
  const std::string broken = dom_in_chromium(page, dir.path());
  EXPECT_EQ(broken.find("data-loaded=\"1\""), std::string::npos);
}

}  // namespace
}  // namespace projtour
