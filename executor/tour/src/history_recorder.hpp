#pragma once
// The run's side of the history database (history.hpp): an observer that writes each visit as
// it ends, one transaction a visit, with its proof image. A database that cannot be used ends
// the recording, never the tour: a warning on stderr and a note in report.json.
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/clock.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/history/history.hpp"
#include "projtour/record/events.hpp"
#include "projtour/tour/runner.hpp"

namespace projtour {

class HistoryRecorder : public ExecutorObserver {
 public:
  // nullptr with --no-history. `resume`: the run directory's row is reused, so a resumed run is
  // one run and a visit resumed is one showing.
  static std::unique_ptr<HistoryRecorder> start(const RunOptions& options,
                                                const MissionSpec& mission,
                                                const std::filesystem::path& run_dir,
                                                std::uint64_t seed, const Clock& clock,
                                                std::ostream& err);
  void on_event(const ExecutorEvent& event) override;
  void on_target_done(const TargetRecord& record) override;
  // The run's end; the note of a recording that failed is added to `notes` (report.json).
  void finish(const std::string& outcome, std::vector<std::string>& notes);
  // The run's end when a step hung (the watchdog's thread, the tick thread stuck, perhaps inside
  // this recorder's own write): the row is ended through a connection of its own that waits at
  // most `busy_timeout_ms`, so the run does not stay `running` for ever.
  void finish_after_hang(const std::string& outcome, double mission_s,
                         std::vector<std::string>& notes, int busy_timeout_ms);

  bool recording() const { return db_ != nullptr; }
  const std::string& run_id() const { return run_.id; }

 private:
  HistoryRecorder(const Clock& clock, std::ostream& err) : clock_(clock), err_(err) {}
  void fail(const std::string& what);
  double unix_at(double mission_s) const;

  const Clock& clock_;
  const MissionSpec* mission_ = nullptr;
  std::ostream& err_;
  std::unique_ptr<HistoryDb> db_;
  std::filesystem::path file_;
  // run_ is written only by start and finish, on the tick thread, so the watchdog's thread may
  // read it; note_ is shared with that thread.
  HistoryRun run_;
  std::filesystem::path run_dir_;
  // A dry run's times are the run's start plus mission time (its clock runs far faster than the
  // wall's), so a rehearsed day spreads over its hours as the real one would.
  double dry_base_unix_s_ = 0.0;
  std::optional<std::string> visiting_;
  double visit_start_unix_s_ = 0.0;
  double visit_start_wall_s_ = 0.0;
  std::mutex note_mutex_;
  std::string note_;
};

}  // namespace projtour
