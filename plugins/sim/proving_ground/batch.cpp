#include "batch.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

extern char** environ;

namespace projtour::ground {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) out.push_back(cell);
  return out;
}

// The case's seed is the last column of its visits' rows.
std::map<std::string, std::string> case_seeds(const fs::path& ground) {
  std::ifstream in(ground / "visits.csv");
  if (!in) throw std::runtime_error((ground / "visits.csv").string() + ": cannot read");
  std::string line;
  std::getline(in, line);
  std::map<std::string, std::string> seeds;
  while (std::getline(in, line)) {
    const auto cells = split_csv(line);
    if (cells.size() > 2) seeds[cells.front()] = cells.back();
  }
  return seeds;
}

pid_t spawn_case(const fs::path& dir, const fs::path& projtour, const std::string& seed) {
  const std::vector<std::string> args = {projtour.string(),
                                         "run",
                                         (dir / "mission.yaml").string(),
                                         "--dry-run",
                                         "--world",
                                         (dir / "world.yaml").string(),
                                         "--seed",
                                         seed,
                                         "--out",
                                         (dir / "run").string(),
                                         "--no-monitor",
                                         "--no-history"};
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error(projtour.string() + ": cannot start: " + std::strerror(rc));
  return pid;
}

// The targets a run's navigate reached (an outcome "succeeded" of a state .../navigate), from its
// events.jsonl.
std::set<std::string> arrived_targets(const fs::path& run_dir) {
  std::set<std::string> arrived;
  std::ifstream in(run_dir / "events.jsonl");
  std::string line;
  const std::string tail = "/navigate";
  while (std::getline(in, line)) {
    const auto e = nlohmann::json::parse(line, nullptr, false);
    if (!e.is_object() || e.value("event", "") != "outcome" || !e["target"].is_string()) continue;
    const std::string state = e.value("state", "");
    if (state.size() >= tail.size() &&
        state.compare(state.size() - tail.size(), tail.size(), tail) == 0 &&
        e.value("outcome", "") == "succeeded") {
      arrived.insert(e["target"].get<std::string>());
    }
  }
  return arrived;
}

}  // namespace

int run_cases(const fs::path& ground, const fs::path& projtour, int jobs, std::ostream& log) {
  const auto seeds = case_seeds(ground);
  std::vector<std::pair<std::string, std::string>> todo;
  for (const auto& [name, seed] : seeds) {
    if (!fs::exists(ground / name / "run" / "report.json")) todo.emplace_back(name, seed);
  }
  std::map<pid_t, std::string> running;
  std::size_t next = 0;
  int failed = 0, done = 0;
  while (next < todo.size() || !running.empty()) {
    while (next < todo.size() && static_cast<int>(running.size()) < jobs) {
      const auto& [name, seed] = todo[next++];
      fs::remove_all(ground / name / "run");
      running[spawn_case(ground / name, projtour, seed)] = name;
    }
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    ++done;
    log << "[" << done << "/" << todo.size() << "] " << it->second << ": exit " << code << "\n";
    // projtour's exit status: 0 all projected, 3 some skipped; 1 (aborted), 2 (invalid input:
    // a generator bug) and the rest are failed runs.
    if (code != 0 && code != 3) ++failed;
    running.erase(it);
  }
  return failed;
}

GroundResults read_results(const fs::path& ground) {
  GroundResults results;
  std::ifstream in(ground / "visits.csv");
  if (!in) throw std::runtime_error((ground / "visits.csv").string() + ": cannot read");
  std::string line;
  std::getline(in, line);
  results.columns = split_csv(line);
  const auto column = [&](const std::string& name) {
    const auto it = std::find(results.columns.begin(), results.columns.end(), name);
    if (it == results.columns.end()) throw std::runtime_error("visits.csv has no column " + name);
    return static_cast<std::size_t>(it - results.columns.begin());
  };
  const std::size_t mission_col = column("mission"), target_col = column("target"),
                    tolerance_col = column("tolerance_mm");
  std::map<std::string, nlohmann::json> reports;
  std::map<std::string, std::set<std::string>> arrivals;
  while (std::getline(in, line)) {
    VisitResult v;
    v.factors = split_csv(line);
    if (v.factors.size() != results.columns.size()) continue;
    v.tolerance_mm = std::stod(v.factors[tolerance_col]);
    const std::string& mission = v.factors[mission_col];
    if (reports.count(mission) == 0) {
      std::ifstream report(ground / mission / "run" / "report.json");
      reports[mission] = report ? nlohmann::json::parse(report, nullptr, false) : nlohmann::json();
    }
    if (arrivals.count(mission) == 0) arrivals[mission] = arrived_targets(ground / mission / "run");
    const nlohmann::json& report = reports[mission];
    if (report.is_object() && report.contains("targets")) {
      for (const auto& t : report["targets"]) {
        if (t.value("id", "") != v.factors[target_col]) continue;
        v.ran = true;
        v.outcome = t.value("outcome", "");
        v.reason = t.value("reason", "");
        if (t.contains("observed_error_mm")) v.observed_mm = t["observed_error_mm"].get<double>();
        if (t.contains("projection_error_mm")) {
          v.true_mm = t["projection_error_mm"]["after_align"].get<double>();
        }
      }
    }
    // A visit the robot never reached (no navigate that succeeded) says nothing of the verdict.
    v.reachable = v.ran && arrivals[mission].count(v.factors[target_col]) > 0;
    results.visits.push_back(std::move(v));
  }
  return results;
}

double upper_bound_95(int k, int n) {
  if (n <= 0) return 1.0;
  if (k >= n) return 1.0;
  // P(X <= k) for X ~ Binomial(n, p), decreasing in p: the bound is where it falls to 5 %.
  const auto cdf = [&](double p) {
    double sum = 0.0;
    for (int i = 0; i <= k; ++i) {
      const double log_term = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) -
                              std::lgamma(n - i + 1.0) + i * std::log(p) + (n - i) * std::log1p(-p);
      sum += std::exp(log_term);
    }
    return sum;
  };
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = (lo + hi) / 2.0;
    (cdf(mid) > 0.05 ? lo : hi) = mid;
  }
  return hi;
}

namespace {

struct Bin {
  std::string label;
  std::function<bool(const VisitResult&)> holds;
};

std::string pct(double v) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1) << 100.0 * v << " %";
  return s.str();
}

std::string mm(double v) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << v;
  return s.str();
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::round(q * (v.size() - 1)))];
}

void write_row(const std::string& factor, const std::string& bin,
               const std::vector<const VisitResult*>& visits, std::ostream& out) {
  int reachable = 0, projected = 0, false_successes = 0;
  std::vector<double> diff, size;
  for (const VisitResult* v : visits) {
    reachable += v->reachable;
    projected += v->outcome == "projected";
    false_successes += v->false_success();
    if (v->observed_mm && v->true_mm) {
      diff.push_back(*v->observed_mm - *v->true_mm);
      size.push_back(std::abs(*v->observed_mm - *v->true_mm));
    }
  }
  out << "| " << factor << " | " << bin << " | " << visits.size() << " | " << reachable << " | "
      << projected << " | " << (reachable ? pct(double(projected) / reachable) : "-") << " | "
      << false_successes << " | " << pct(upper_bound_95(false_successes, projected)) << " | "
      << (diff.empty() ? "-" : mm(quantile(diff, 0.5))) << " | "
      << (size.empty() ? "-" : mm(quantile(size, 0.95))) << " |\n";
}

}  // namespace

void write_table(const GroundResults& results, std::ostream& out) {
  const auto col = [&](const std::string& name) {
    const auto it = std::find(results.columns.begin(), results.columns.end(), name);
    if (it == results.columns.end()) throw std::runtime_error("visits.csv has no column " + name);
    return static_cast<std::size_t>(it - results.columns.begin());
  };
  const auto number = [&](const std::string& name) {
    const std::size_t c = col(name);
    return [c](const VisitResult& v) { return std::stod(v.factors[c]); };
  };
  const auto range = [&](const std::string& name, double lo, double hi) {
    auto value = number(name);
    const std::string label = hi >= 1e6 ? "≥ " + mm(lo) : "[" + mm(lo) + ", " + mm(hi) + ")";
    return Bin{label,
               [value, lo, hi](const VisitResult& v) { return value(v) >= lo && value(v) < hi; }};
  };
  std::vector<std::pair<std::string, std::vector<Bin>>> factors = {
      {"all", {Bin{"all", [](const VisitResult&) { return true; }}}},
      {"model_error_mm",
       {range("model_error_mm", 0, 1), range("model_error_mm", 1, 2), range("model_error_mm", 2, 3),
        range("model_error_mm", 3, 4.01)}},
      {"calibration_error_mm",
       {range("calibration_error_mm", 0, 5), range("calibration_error_mm", 5, 10.01)}},
      {"calibration_error_deg",
       {range("calibration_error_deg", 0, 0.5), range("calibration_error_deg", 0.5, 1.01)}},
      {"target_offset_m", {range("target_offset_m", 0, 0.1), range("target_offset_m", 0.1, 0.21)}},
      {"target_offset_deg",
       {range("target_offset_deg", 0, 10), range("target_offset_deg", 10, 20.01)}},
      {"standoff_m", {range("standoff_m", 0.8, 1.2), range("standoff_m", 1.2, 1.61)}},
      {"content_curvature_mm",
       {range("content_curvature_mm", 0, 1), range("content_curvature_mm", 1, 1e6)}},
      {"people", {range("people", 0, 1), range("people", 1, 4)}},
  };
  for (const std::string name : {"half", "map", "mesh"}) {
    const std::size_t c = col(name);
    std::vector<std::string> values;
    for (const auto& v : results.visits) {
      if (std::find(values.begin(), values.end(), v.factors[c]) == values.end()) {
        values.push_back(v.factors[c]);
      }
    }
    std::sort(values.begin(), values.end());
    std::vector<Bin> bins;
    for (const auto& value : values) {
      bins.push_back(
          Bin{value, [c, value](const VisitResult& v) { return v.factors[c] == value; }});
    }
    factors.emplace_back(name, std::move(bins));
  }
  out << "| factor | bin | visits | reachable | projected | yield | false successes | "
         "95 % upper bound | observed − true, median mm | abs, 95th pct mm |\n"
      << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& [factor, bins] : factors) {
    for (const Bin& bin : bins) {
      std::vector<const VisitResult*> in;
      for (const auto& v : results.visits) {
        if (v.ran && bin.holds(v)) in.push_back(&v);
      }
      if (!in.empty()) write_row(factor, bin.label, in, out);
    }
  }
}

}  // namespace projtour::ground
