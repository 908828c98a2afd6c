// The history database's cost: BM_InsertVisit records simulated 8-hour days of
// missions/all_day.yaml (the dry run's shape, seed 1: 17 rounds of its six targets, 09:00 to
// 17:00; the rabbit and the west pillar only in their lunch-time windows, else outside_hours;
// 78 of 102 visits projected, each with an 8 s dwell and a proof JPEG) into a database already
// holding `range(0)` days, each visit as the recorder does it (proof image made from a 640x480
// colour view, stored by its SHA-256, one transaction). Its counters: the database and the proof
// images after the last day, per day. BM_MonthSummary is `projtour history`'s per-content
// summary over 30 such days (the target: at most 200 ms), BM_MonthSummaryCommand the same as the
// whole command in a process of its own, BM_MonthPage the --html page.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "projtour/history/history.hpp"
#include "projtour/tour/history_proof.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

constexpr int kRounds = 17;
constexpr double kRoundS = 1500.0 + 228.0;  // the pause and one pass of the tour, seconds
constexpr double kDay0 = 1772323200.0;      // 2026-03-01T00:00:00Z
constexpr double kNineS = 9 * 3600.0;

struct Target {
  const char* id;
  std::vector<const char*> contents;
  double open_s, close_s;  // hours (seconds of the day)
};

const std::vector<Target>& targets() {
  static const std::vector<Target> t = {
      {"open-day-sign", {"sign.png", "sale.png"}, 0, 86400},
      {"rabbit", {"lunch.png", "lunch.avi"}, 11.5 * 3600, 14 * 3600},
      {"pillar-east", {"pillar.png"}, 0, 86400},
      {"rabbit-west", {"sale.png"}, 0, 86400},
      {"pillar-west", {"lunch.avi", "pillar.png"}, 12 * 3600, 14.5 * 3600},
      {"sign-south", {"sign.png"}, 0, 86400}};
  return t;
}

// A colour view like verify's camera_view.png (640x480: a lit quad on a grey, noisy scene with
// the corner marks), noise seeded per visit so no two proofs are the same bytes.
fs::path colour_view(const fs::path& dir, unsigned seed) {
  cv::Mat view(480, 640, CV_8UC3);
  for (int y = 0; y < view.rows; ++y) {
    view.row(y).setTo(cv::Scalar(60 + y / 8, 62 + y / 8, 64 + y / 8));
  }
  cv::Mat noise(view.size(), CV_8UC3);
  cv::theRNG().state = seed;
  cv::randn(noise, cv::Scalar::all(0), cv::Scalar::all(6));
  view += noise;
  const std::vector<cv::Point> quad = {{240, 150}, {420, 160}, {410, 330}, {250, 320}};
  cv::fillConvexPoly(view, quad, cv::Scalar(225, 225, 225), cv::LINE_AA);
  for (const cv::Point& p : quad) cv::circle(view, p, 6, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  const fs::path file = dir / ("view" + std::to_string(seed % 64) + ".png");
  cv::imwrite(file.string(), view);
  return file;
}

// One simulated day's visits, recorded as the run's recorder records them; returns the count and
// adds to `recording_s` the time spent as the recorder spends it (the colour view, which verify
// writes, is made outside it).
int record_day(HistoryDb& db, const fs::path& views, int day, std::mt19937& random,
               double& recording_s) {
  using Clock = std::chrono::steady_clock;
  std::normal_distribution<double> observed(1.0, 0.4);
  const std::string run = "run-day-" + std::to_string(day);
  HistoryRun r;
  r.id = run;
  r.mission = "all-day";
  r.robot = "ud";
  r.run_dir = "/runs/" + run;
  r.started_at_s = kDay0 + 86400.0 * day + kNineS;
  r.seed = 1;
  auto start = Clock::now();
  db.upsert_run(r);
  recording_s += std::chrono::duration<double>(Clock::now() - start).count();
  int count = 0;
  for (int round = 1; round <= kRounds; ++round) {
    const double round_s = r.started_at_s + (round - 1) * kRoundS;
    int i = 0;
    for (const Target& t : targets()) {
      fs::path view;
      HistoryVisit v;
      v.run_id = run;
      v.round = round;
      v.target = t.id;
      v.content = t.contents[static_cast<std::size_t>(round) % t.contents.size()];
      v.started_at_s = round_s + 38.0 * i++;
      const double of_day = v.started_at_s - kDay0 - 86400.0 * day;
      if (of_day < t.open_s || of_day >= t.close_s) {
        v.ended_at_s = v.started_at_s;
        v.outcome = "outside_hours";
        v.reason = "outside its hours";
      } else {
        v.ended_at_s = v.started_at_s + 36.0;
        v.shown_s = 8.0;
        v.observed_error_mm = std::abs(observed(random));
        v.true_error_mm = 0.7 * *v.observed_error_mm;
        v.outcome = "projected";
        view = colour_view(views, static_cast<unsigned>(random()));
      }
      start = Clock::now();
      if (!view.empty()) {
        const std::vector<unsigned char> jpeg = proof_jpeg_from(view);
        const StoredProof proof = store_proof(db.file(), jpeg);
        v.proof_path = proof.relative_path;
        v.proof_sha256 = proof.sha256;
      }
      db.record_visit(v);
      recording_s += std::chrono::duration<double>(Clock::now() - start).count();
      ++count;
    }
  }
  return count;
}

std::uintmax_t bytes_under(const fs::path& path) {
  std::uintmax_t total = 0;
  if (fs::is_regular_file(path)) return fs::file_size(path);
  if (!fs::exists(path)) return 0;
  for (const auto& e : fs::recursive_directory_iterator(path)) {
    if (e.is_regular_file()) total += e.file_size();
  }
  return total;
}

void BM_InsertVisit(benchmark::State& state) {
  const int days_before = static_cast<int>(state.range(0));
  test::TempDir dir("bench_history");
  std::mt19937 random(1);
  std::int64_t visits = 0;
  std::uintmax_t db_bytes = 0, proof_bytes = 0;
  for (auto _ : state) {
    const fs::path file = dir.path() / ("h" + std::to_string(visits) + ".sqlite");
    auto db = std::make_unique<HistoryDb>(file, HistoryAccess::read_write);
    double ignored_s = 0.0, recording_s = 0.0;
    for (int d = 0; d < days_before; ++d) record_day(*db, dir.path(), d, random, ignored_s);
    visits += record_day(*db, dir.path(), days_before, random, recording_s);
    state.SetIterationTime(recording_s);
    db.reset();  // the WAL checkpointed into the file: its size is the database's
    db_bytes = bytes_under(file);
    proof_bytes = bytes_under(proofs_dir_of(file));
    fs::remove_all(proofs_dir_of(file));
    fs::remove(file);
  }
  state.SetItemsProcessed(visits);
  state.counters["days"] = days_before + 1;
  state.counters["db_bytes"] = static_cast<double>(db_bytes);
  state.counters["proof_bytes"] = static_cast<double>(proof_bytes);
}
// The time is a day's: divide by its 102 visits (items_per_second is visits per second).
BENCHMARK(BM_InsertVisit)
    ->Arg(0)
    ->Arg(29)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// 30 days in one database, made once.
struct Month {
  test::TempDir dir{"bench_history_month"};
  fs::path file = dir.path() / "month.sqlite";
  Month() {
    std::mt19937 random(1);
    HistoryDb db(file, HistoryAccess::read_write);
    double recording_s = 0.0;
    for (int d = 0; d < 30; ++d) record_day(db, dir.path(), d, random, recording_s);
    // PROJTOUR_BENCH_HISTORY_OUT=DIR keeps the month (database and proofs) there, to time
    // `projtour history` on it end to end.
    if (const char* out = std::getenv("PROJTOUR_BENCH_HISTORY_OUT")) {
      fs::create_directories(out);
      fs::copy_file(file, fs::path(out) / file.filename(), fs::copy_options::overwrite_existing);
      fs::copy(proofs_dir_of(file), proofs_dir_of(fs::path(out) / file.filename()),
               fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    }
  }
};
const Month& month() {
  static const Month m;
  return m;
}

void BM_MonthSummary(benchmark::State& state) {
  const Month& m = month();
  HistoryQuery q;
  q.from_s = kDay0;
  q.to_s = kDay0 + 30 * 86400.0;
  q.by = state.range(0) == 0 ? "content" : "day";
  std::size_t rows = 0;
  for (auto _ : state) {
    // Opened each time, as the command does (quick_check included).
    HistoryDb db(m.file, HistoryAccess::read_only);
    rows = summarize_history(db, q).size();
    benchmark::DoNotOptimize(rows);
  }
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["db_bytes"] = static_cast<double>(bytes_under(m.file));
  state.counters["proof_bytes"] = static_cast<double>(bytes_under(proofs_dir_of(m.file)));
}
BENCHMARK(BM_MonthSummary)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The whole `projtour history` command over the month, as a person or a dashboard's script
// runs it: a process started, the launcher loaded, the database opened and summed, the table
// printed (to /dev/null), the process gone.
void BM_MonthSummaryCommand(benchmark::State& state) {
  const Month& m = month();
  const std::string exe = test::projtour_binary().string();
  std::vector<std::string> args = {exe,      "history",    "--history", m.file.string(),
                                   "--from", "2026-03-01", "--to",      "2026-03-30"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  for (auto _ : state) {
    pid_t child = 0;
    if (posix_spawn(&child, exe.c_str(), &quiet, nullptr, argv.data(), environ) != 0) {
      state.SkipWithError("cannot start projtour");
      break;
    }
    int status = 0;
    if (::waitpid(child, &status, 0) != child || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      state.SkipWithError("projtour history failed");
      break;
    }
  }
  posix_spawn_file_actions_destroy(&quiet);
}
// Real time: the work is the child's, the benchmark's own CPU time only the spawn and the wait.
BENCHMARK(BM_MonthSummaryCommand)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_MonthPage(benchmark::State& state) {
  const Month& m = month();
  HistoryQuery q;
  for (auto _ : state) {
    HistoryDb db(m.file, HistoryAccess::read_only);
    write_history_page(db, q, m.dir.path() / "page.html");
  }
  state.counters["page_bytes"] = static_cast<double>(bytes_under(m.dir.path() / "page.html"));
}
BENCHMARK(BM_MonthPage)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
