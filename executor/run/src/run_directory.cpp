#include "projtour/run/run_directory.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <utility>
#include <vector>

#include "projtour/contract/run_files.hpp"

namespace projtour {
namespace {

constexpr const char* kLockName = ".lock";

std::string system_error(const std::string& what, const std::filesystem::path& p, int err) {
  return what + " " + p.string() + ": " + std::strerror(err);
}

// What the directory holds besides the lock (and an empty targets/, all a run refused or killed
// before its first target leaves), for the message refusing it (a few names).
std::vector<std::string> entries_besides_lock(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name == kLockName) continue;
    std::error_code ignored;
    if (name == "targets" && !it->is_symlink(ignored) && it->is_directory(ignored) &&
        std::filesystem::is_empty(it->path(), ignored)) {
      continue;
    }
    names.push_back(name);
  }
  if (ec) throw RunDirectoryError(system_error("cannot read", dir, ec.value()));
  return names;
}

void refuse_if_it_holds_a_run(const std::filesystem::path& dir) {
  std::vector<std::string> names = entries_besides_lock(dir);
  if (names.empty()) return;
  std::sort(names.begin(), names.end());
  std::string listed;
  for (std::size_t i = 0; i < names.size() && i < 3; ++i) {
    listed += (i ? ", " : "") + names[i];
  }
  if (names.size() > 3) listed += ", ...";
  throw RunDirectoryError(dir.string() + " already holds files (" + listed +
                          "): continue its run with --resume, or choose another --out");
}

void refuse_links(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::recursive_directory_iterator it(dir, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    if (it->is_symlink(ec)) {
      throw RunDirectoryError(it->path().string() +
                              " is a symbolic link: a run directory holds only the run's own "
                              "files, and projtour does not write through links");
    }
  }
  if (ec) throw RunDirectoryError(system_error("cannot read", dir, ec.value()));
}

std::string stamp_now() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &local);
  return stamp;
}

// mkdir is the claim: of two runs started in the same second, one makes NAME and the other
// finds it taken and makes NAME-2.
std::filesystem::path fresh_default_dir(const std::string& mission_name) {
  const std::filesystem::path runs = "runs";
  std::error_code ec;
  std::filesystem::create_directories(runs, ec);
  if (ec) throw RunDirectoryError(system_error("cannot create", runs, ec.value()));
  const std::string base = mission_name + "-" + stamp_now();
  constexpr int kMaxSameSecond = 1000;
  for (int n = 1; n <= kMaxSameSecond; ++n) {
    const std::filesystem::path dir = runs / (n == 1 ? base : base + "-" + std::to_string(n));
    if (::mkdir(dir.c_str(), 0755) == 0) return dir;
    if (errno != EEXIST) throw RunDirectoryError(system_error("cannot create", dir, errno));
  }
  throw RunDirectoryError("cannot create a run directory: runs/" + base + " and " +
                          std::to_string(kMaxSameSecond - 1) + " more exist");
}

// The pid the holder wrote into .lock; the file only names it (the lock is on the directory,
// so deleting .lock does not free it), and it is read without following a link or waiting on
// a FIFO.
std::string holder_of(const std::filesystem::path& dir) {
  const std::filesystem::path lock = dir / kLockName;
  const int fd = ::open(lock.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return "unknown";
  struct stat st {};
  char pid[32] = {};
  const ssize_t n =
      ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) ? ::pread(fd, pid, sizeof pid - 1, 0) : -1;
  ::close(fd);
  std::string holder = n > 0 ? std::string(pid, static_cast<std::size_t>(n)) : "";
  while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
  const bool digits = !holder.empty() && std::all_of(holder.begin(), holder.end(),
                                                     [](char c) { return c >= '0' && c <= '9'; });
  return digits ? holder : std::string("unknown");
}

RunDirectoryError in_use(const std::filesystem::path& dir) {
  return RunDirectoryError(dir.string() + " is in use by another projtour run (pid " +
                           holder_of(dir) + "): one run directory, one run at a time");
}

// A run holding the directory is the first thing to say of it; the probe creates nothing.
void refuse_if_held(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  if (held) throw in_use(dir);
}

// The lock is the directory's own: flock on the held descriptor, which no rename or unlink of
// a file inside can undo.
std::unique_ptr<HeldRunDirectory> hold_and_lock(const std::filesystem::path& dir) {
  std::unique_ptr<HeldRunDirectory> held;
  try {
    held = std::make_unique<HeldRunDirectory>(dir);
  } catch (const std::exception& e) {
    throw RunDirectoryError(e.what());
  }
  if (::flock(held->fd(), LOCK_EX | LOCK_NB) != 0) {
    if (errno != EWOULDBLOCK) throw RunDirectoryError(system_error("cannot lock", dir, errno));
    throw in_use(dir);
  }
  try {
    write_run_file(dir / kLockName, std::to_string(::getpid()) + "\n");
  } catch (const std::exception& e) {
    throw RunDirectoryError(e.what());
  }
  return held;
}

}  // namespace

RunDirectory RunDirectory::claim(const std::optional<std::filesystem::path>& out, bool resume,
                                 const std::string& mission_name) {
  if (out && out->empty()) {
    throw RunDirectoryError(
        "--out \"\" names no directory (the run would land in the current one)");
  }
  if (resume && !out) throw RunDirectoryError("--resume needs --out DIR (the run to continue)");
  std::filesystem::path dir;
  if (!out) {
    dir = fresh_default_dir(mission_name);
  } else {
    dir = *out;
    std::error_code ec;
    const auto status = std::filesystem::status(dir, ec);
    if (resume && !std::filesystem::is_directory(status)) {
      throw RunDirectoryError("cannot resume: " + dir.string() + " is not a run directory");
    }
    if (std::filesystem::exists(status) && !std::filesystem::is_directory(status)) {
      throw RunDirectoryError(dir.string() + " exists and is not a directory");
    }
    // Before the lock is made: a directory refused must be left exactly as it was.
    if (std::filesystem::exists(status)) refuse_if_held(dir);
    if (!resume && std::filesystem::exists(status)) refuse_if_it_holds_a_run(dir);
    std::filesystem::create_directories(dir, ec);
    if (ec) throw RunDirectoryError(system_error("cannot create", dir, ec.value()));
  }
  RunDirectory claimed(dir, hold_and_lock(dir));
  // Under the lock, again: another run may have started between the look and the lock.
  if (!resume) {
    refuse_if_it_holds_a_run(dir);
  } else {
    refuse_links(dir);
  }
  try {
    make_run_directory(dir / "targets");
  } catch (const std::exception& e) {
    throw RunDirectoryError(e.what());
  }
  return claimed;
}

RunDirectory::RunDirectory(std::filesystem::path path, std::unique_ptr<HeldRunDirectory> held)
    : path_(std::move(path)), held_(std::move(held)) {}

RunDirectory::RunDirectory(RunDirectory&& other) noexcept = default;

RunDirectory::~RunDirectory() = default;

std::string RunDirectory::first_write_failure() const {
  return held_ ? held_->first_failure() : std::string();
}

}  // namespace projtour
