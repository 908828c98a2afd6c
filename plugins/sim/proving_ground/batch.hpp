#pragma once
// Running a proving ground's cases (each a `projtour run --dry-run` of its own) and the table of
// what they gave, cut by the factors they were drawn with.
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace projtour::ground {

// Runs every case under `ground` that has no report yet, `jobs` at a time, with `projtour`.
// Returns the number of cases whose run exited with neither 0 (all projected) nor 3 (some skipped).
int run_cases(const std::filesystem::path& ground, const std::filesystem::path& projtour, int jobs,
              std::ostream& log);

// One visit as drawn and as run.
struct VisitResult {
  std::vector<std::string> factors;  // visits.csv's row, in its columns' order
  bool ran = false;                  // the case's report exists and lists the target
  std::string outcome;               // "projected", "skipped", ...
  std::string reason;
  bool reachable = false;             // navigate reached the stand-off (the run's events say so)
  std::optional<double> observed_mm;  // the robot's figure
  std::optional<double> true_mm;      // the referee's, at the Model Points
  double tolerance_mm = 0.0;
  bool false_success() const {
    return outcome == "projected" && true_mm && *true_mm > tolerance_mm;
  }
};

struct GroundResults {
  std::vector<std::string> columns;  // visits.csv's header
  std::vector<VisitResult> visits;
};

GroundResults read_results(const std::filesystem::path& ground);

// The 95 % upper confidence bound (one-sided, Clopper-Pearson) of a rate seen k times in n.
double upper_bound_95(int k, int n);

// The table (Markdown): per factor bin the visits, reachable, projected, yield, false successes
// with their 95 % upper bound, and observed minus true (median, 95th percentile of its size).
void write_table(const GroundResults& results, std::ostream& out);

}  // namespace projtour::ground
