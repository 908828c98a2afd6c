#pragma once
// Child processes, above all the `projtour` command: argv, environment, output to files, exit
// status, a time limit, and a way to stop the child at an exact point of its run.
#include <sys/types.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace projtour::test {

struct ChildOptions {
  std::vector<std::string> argv;  // argv[0] is the program's path
  // Set (a value) or removed (nullopt) in the child's environment; the rest is inherited.
  std::map<std::string, std::optional<std::string>> env;
  // Where stdout and stderr go. Empty: files of a temp dir the Child owns.
  std::filesystem::path stdout_file;
  std::filesystem::path stderr_file;
  // The child stops itself (SIGSTOP) right after its first write(2) whose bytes contain this
  // text (with a preloaded shim, so the program is not changed): e.g. one events.jsonl line.
  std::optional<std::string> stop_after_write;
  // The child stops itself right after it installs a handler for this signal.
  std::optional<int> stop_after_handler_for;
};

class Child {
 public:
  explicit Child(ChildOptions options);
  // SIGKILLs a child still running (or stopped), so a failing test leaves none behind.
  ~Child();
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) const;
  // The exit status once the child has exited (non-blocking), -signal if a signal ended it.
  std::optional<int> poll();
  // Waits up to `limit` for the exit; SIGKILLs the child past it (then timed_out()).
  int wait(std::chrono::milliseconds limit);
  bool timed_out() const { return timed_out_; }
  // Waits up to `limit` for the child to stop itself (stop_after_write, stop_after_handler_for);
  // false when it exited or the limit passed first. `meanwhile` runs between polls.
  template <typename F>
  bool wait_stopped(std::chrono::milliseconds limit, F&& meanwhile);
  bool wait_stopped(std::chrono::milliseconds limit) {
    return wait_stopped(limit, [] {});
  }
  bool stopped() const { return stopped_; }
  // Continues a stopped child (SIGCONT); signals sent while it was stopped are delivered first.
  void resume();

  std::string out() const;  // what the child wrote to stdout so far
  std::string err() const;
  const std::filesystem::path& stdout_file() const { return options_.stdout_file; }
  const std::filesystem::path& stderr_file() const { return options_.stderr_file; }

 private:
  bool check_stopped_or_exited();
  static int decode(int status);
  ChildOptions options_;
  std::filesystem::path own_dir_;
  pid_t pid_ = -1;
  std::optional<int> status_;
  bool stopped_ = false;
  bool timed_out_ = false;
};

template <typename F>
bool Child::wait_stopped(std::chrono::milliseconds limit, F&& meanwhile) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!check_stopped_or_exited()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    meanwhile();
    ::usleep(2000);
  }
  return stopped_;
}

struct RunResult {
  int status = -1;  // exit status, -signal
  bool timed_out = false;
  std::string out;
  std::string err;
};

// Runs to the end (SIGKILL past `limit`).
RunResult run(ChildOptions options, std::chrono::milliseconds limit = std::chrono::seconds(300));

// The build's projtour command and plugin directory.
std::filesystem::path projtour_binary();
std::filesystem::path plugin_build_dir();

// `projtour args...`, stdout and stderr to log_prefix.stdout / .stderr when a prefix is given.
ChildOptions projtour_command(const std::vector<std::string>& args,
                              const std::filesystem::path& log_prefix = {});
RunResult run_projtour(const std::vector<std::string>& args,
                       const std::filesystem::path& log_prefix = {},
                       std::chrono::milliseconds limit = std::chrono::seconds(300));

// A command line split into words as a POSIX shell would for plain words and '...' / "..."
// quotes (no expansions): for tests that write a command as one string.
std::vector<std::string> shell_words(const std::string& line);

}  // namespace projtour::test
