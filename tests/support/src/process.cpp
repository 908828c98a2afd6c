#include "projtour_test/process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <stdexcept>
#include <thread>

#include "projtour_test/run_files.hpp"
#include "projtour_test/temp_dir.hpp"

extern char** environ;

namespace projtour::test {

namespace fs = std::filesystem;

namespace {

// The child's environment: ours with `changes` applied.
std::vector<std::string> child_environment(
    const std::map<std::string, std::optional<std::string>>& changes) {
  std::map<std::string, std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    const auto eq = entry.find('=');
    if (eq != std::string::npos) env[entry.substr(0, eq)] = entry.substr(eq + 1);
  }
  for (const auto& [name, value] : changes) {
    if (value) {
      env[name] = *value;
    } else {
      env.erase(name);
    }
  }
  std::vector<std::string> out;
  for (const auto& [name, value] : env) out.push_back(name + "=" + value);
  return out;
}

void add_stop_shim(ChildOptions& options) {
  auto& preload = options.env["LD_PRELOAD"];
  const char* inherited = std::getenv("LD_PRELOAD");
  preload = std::string(PROJTOUR_TEST_STOP_SHIM) +
            (inherited != nullptr && *inherited != '\0' ? std::string(":") + inherited : "");
  // Under the sanitizers the ASan runtime refuses to start when it is not the first library;
  // the shim, built without them, calls nothing of it.
  const char* asan = std::getenv("ASAN_OPTIONS");
  options.env["ASAN_OPTIONS"] = (asan != nullptr && *asan != '\0' ? std::string(asan) + ":" : "") +
                                "verify_asan_link_order=0";
  if (options.stop_after_write) {
    options.env["PROJTOUR_TEST_STOP_AFTER_WRITE"] = *options.stop_after_write;
  }
  if (options.stop_after_handler_for) {
    options.env["PROJTOUR_TEST_STOP_AFTER_HANDLER"] =
        std::to_string(*options.stop_after_handler_for);
  }
}

}  // namespace

Child::Child(ChildOptions options) : options_(std::move(options)) {
  if (options_.argv.empty()) throw std::invalid_argument("Child: empty argv");
  if (options_.stdout_file.empty() || options_.stderr_file.empty()) {
    TempDir own("child");
    own_dir_ = own.path();
    own.keep();  // removed by ~Child, after the output has been read
    if (options_.stdout_file.empty()) options_.stdout_file = own_dir_ / "stdout";
    if (options_.stderr_file.empty()) options_.stderr_file = own_dir_ / "stderr";
  }
  // A run records into the history database of the user's data directory by default: a child
  // gets the test's own, so no test touches the real home and parallel tests never share one
  // unless a test sets XDG_DATA_HOME (or passes --history) to mean to.
  if (options_.env.count("XDG_DATA_HOME") == 0) {
    options_.env["XDG_DATA_HOME"] = (scratch_dir() / "xdg-data").string();
  }
  if (options_.stop_after_write || options_.stop_after_handler_for) add_stop_shim(options_);

  // Everything the child needs is built before fork: after it, only async-signal-safe calls.
  std::vector<std::string> env_strings = child_environment(options_.env);
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_strings = options_.argv;
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  const std::string out_path = options_.stdout_file.string();
  const std::string err_path = options_.stderr_file.string();

  pid_ = ::fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out < 0 || err < 0) ::_exit(126);
    ::dup2(out, STDOUT_FILENO);
    ::dup2(err, STDERR_FILENO);
    ::execve(argv[0], argv.data(), envp.data());
    ::_exit(127);
  }
}

Child::~Child() {
  if (!status_ && pid_ > 0) {
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }
  if (!own_dir_.empty()) {
    std::error_code ec;
    fs::remove_all(own_dir_, ec);
  }
}

void Child::signal(int sig) const {
  if (!status_) ::kill(pid_, sig);
}

int Child::decode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return -1000;
}

bool Child::check_stopped_or_exited() {
  if (status_ || stopped_) return true;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG | WUNTRACED) == pid_) {
    if (WIFSTOPPED(status)) {
      stopped_ = true;
    } else {
      status_ = decode(status);
    }
  }
  return status_ || stopped_;
}

std::optional<int> Child::poll() {
  if (status_) return status_;
  int status = 0;
  // A stop is not an exit: waitpid without WUNTRACED reports only the end.
  if (::waitpid(pid_, &status, WNOHANG) == pid_) status_ = decode(status);
  return status_;
}

int Child::wait(std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!poll()) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      status_ = -SIGKILL;
      timed_out_ = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return *status_;
}

void Child::resume() {
  stopped_ = false;
  if (!status_) ::kill(pid_, SIGCONT);
}

std::string Child::out() const {
  return read_text_if_exists(options_.stdout_file);
}
std::string Child::err() const {
  return read_text_if_exists(options_.stderr_file);
}

RunResult run(ChildOptions options, std::chrono::milliseconds limit) {
  Child child(std::move(options));
  RunResult r;
  r.status = child.wait(limit);
  r.timed_out = child.timed_out();
  r.out = child.out();
  r.err = child.err();
  return r;
}

fs::path projtour_binary() {
  return fs::path(PROJTOUR_BINARY_DIR) / "projtour";
}
fs::path plugin_build_dir() {
  return PROJTOUR_PLUGIN_BUILD_DIR;
}

ChildOptions projtour_command(const std::vector<std::string>& args, const fs::path& log_prefix) {
  ChildOptions options;
  options.argv = {projtour_binary().string()};
  options.argv.insert(options.argv.end(), args.begin(), args.end());
  if (!log_prefix.empty()) {
    options.stdout_file = log_prefix.string() + ".stdout";
    options.stderr_file = log_prefix.string() + ".stderr";
  }
  return options;
}

RunResult run_projtour(const std::vector<std::string>& args, const fs::path& log_prefix,
                       std::chrono::milliseconds limit) {
  return run(projtour_command(args, log_prefix), limit);
}

std::vector<std::string> shell_words(const std::string& line) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  char quote = 0;
  for (const char c : line) {
    if (quote != 0) {
      if (c == quote) {
        quote = 0;
      } else {
        word += c;
      }
    } else if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (c == ' ' || c == '\t' || c == '\n') {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (quote != 0) throw std::invalid_argument("shell_words: unterminated quote in " + line);
  if (in_word) words.push_back(word);
  return words;
}

}  // namespace projtour::test
