#pragma once
// Runs the real `projtour` command as a child process on the integration missions and reads
// back what a run leaves in its directory, failing loudly on anything truncated or unparsable.
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour_executor/json_io.hpp"

namespace projtour::integration {

namespace fs = std::filesystem;

fs::path data_dir();  // tests/integration/data
std::string read_text(const fs::path& file);

// A dry run of `mission` in `world` writing to `out` at --speed 0 unless `extra` (--seed,
// --resume, --speed) gives another.
std::vector<std::string> dry_run_args(const fs::path& mission, const fs::path& world,
                                      const fs::path& out,
                                      const std::vector<std::string>& extra = {});

// A child `projtour` with stdout and stderr going to files.
class Child {
 public:
  Child(const std::vector<std::string>& args, const fs::path& stdout_file,
        const fs::path& stderr_file);
  ~Child();  // kills (SIGKILL) a child still running, so a failing test leaves none behind
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) const;
  // The exit status once the child has exited (non-blocking), -signal if a signal ended it.
  std::optional<int> poll();
  // Waits up to `limit`; SIGKILLs the child and returns -9 past it.
  int wait(std::chrono::milliseconds limit);

 private:
  static int decode(int status);
  pid_t pid_ = -1;
  std::optional<int> status_;
};

// Runs to the end (at most `limit`); the exit status.
int run_projtour(const std::vector<std::string>& args, const fs::path& log_prefix,
                 std::chrono::milliseconds limit = std::chrono::seconds(300));

// Every line of a JSON-lines file; throws std::runtime_error naming the file and line when a
// line is not JSON or the file does not end with a newline (a line cut in half).
std::vector<Json> read_jsonl(const fs::path& file);
Json read_json(const fs::path& file);

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

// Problems with the projector's safety in a run directory, empty when safe: every lit spell in
// sim_projector_log.jsonl (show .. next blank) starts and ends with the base and head still,
// lies inside one `project` state of the same target (no other step moves anything while lit),
// and the projector is blank when the run ends.
std::vector<std::string> projector_safety_problems(const fs::path& run_dir,
                                                   const std::vector<Json>& events);

}  // namespace projtour::integration
