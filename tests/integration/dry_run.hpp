#pragma once
// Dry runs of the integration missions (the `projtour` child and the JSON readers are the
// support library's) and what the tests look for in their events.
#include <filesystem>
#include <string>
#include <vector>

#include "projtour/formats/json_io.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/run_files.hpp"

namespace projtour::integration {

namespace fs = std::filesystem;
using test::Child;
using test::read_json;
using test::read_jsonl;
using test::read_text;

fs::path data_dir();  // tests/integration/data

// A dry run of `mission` in `world` writing to `out`, unpaced unless `extra` (--seed,
// --resume, --speed) gives another.
std::vector<std::string> dry_run_args(const fs::path& mission, const fs::path& world,
                                      const fs::path& out,
                                      const std::vector<std::string>& extra = {});

// An outcome of a leaf state of a visit, in order: "capture:no_frame".
struct StepOutcome {
  std::string step;  // last path component of the state
  std::string outcome;
  std::string message;
  double t_s = 0.0;
};
// The steps' outcomes of every visit to `target`, then "skip_target" / "finish" when the visit
// ended by that transition. Pass a slice of events to look at one run of several.
std::vector<std::string> outcome_chain(const std::vector<Json>& events, const std::string& target);
std::vector<StepOutcome> step_outcomes(const std::vector<Json>& events, const std::string& target);
std::string join(const std::vector<std::string>& items);

// The report's target record by id (throws when absent).
const Json& report_target(const Json& report, const std::string& id);

// The frames the simulated projector showed on `target` (any target when empty), from the run
// directory's sim_projector_log.jsonl.
int shows_on(const fs::path& run_dir, const std::string& target);

// Problems with the projector's safety in a run directory, empty when safe: every lit spell in
// sim_projector_log.jsonl (show .. next blank) starts and ends with the base and head still,
// lies inside one `calibrate`, `verify` or `project` state of the same target (no other step
// moves anything while lit),
// and the projector is blank when the run ends. A resumed run appends to the log: its lines
// start at `first_log_line`, and only they are checked against the resumed run's `events`.
std::vector<std::string> projector_safety_problems(const fs::path& run_dir,
                                                   const std::vector<Json>& events,
                                                   std::size_t first_log_line = 0);

}  // namespace projtour::integration
