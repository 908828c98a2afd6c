#pragma once
// report.json and the end-of-run table (checkpoint.json: checkpoint.hpp).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "projtour/contract/ground_truth.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/machine/executor.hpp"
#include "projtour/record/checkpoint.hpp"
#include "projtour/record/events.hpp"
#include "projtour/record/target_record.hpp"

namespace projtour {

struct RunSummary {
  std::string mission;
  bool dry_run = false;
  std::uint64_t seed = 1;
  TourOutcome outcome = TourOutcome::running;
  double wall_s = 0.0;
  double mission_s = 0.0;
  std::vector<TargetRecord> targets;  // any order; written in mission order
  std::string reason;                 // why an aborted tour ended; written only when not empty
  std::vector<std::string> ignored_cancel;  // behaviours stopped by force; written when any
  // What the operator should know of how the run went, such as a target visited again on
  // resume because it changed since the checkpoint; written when any.
  std::vector<std::string> notes;
  // The referee's figures of a building that is not the map (dry run); written when present.
  std::optional<BuildingTruth> building;
};

// report.json (README.md, "The command"), and the referee's `building` section of a dry run in a
// busy world.
Json build_report(const RunSummary& summary);

// The per-target table printed at the end of a run.
void print_target_table(const RunSummary& summary, std::ostream& out);

}  // namespace projtour
