#include "projtour/contract/run_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

namespace projtour {

struct HeldRunDirectory::Entry {
  std::filesystem::path root;  // absolute, lexically normal
  int fd = -1;
  mutable std::mutex mutex;
  std::string failure;

  void note(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex);
    if (failure.empty()) failure = what;
  }
};

namespace {

using Entry = HeldRunDirectory::Entry;

std::runtime_error failure(const std::string& what, const std::filesystem::path& file, int err) {
  return std::runtime_error(what + " " + file.string() + ": " + std::strerror(err));
}

std::runtime_error link_refused(const std::filesystem::path& link) {
  return std::runtime_error("refusing to write through the symbolic link " + link.string() +
                            " (a run directory holds only the run's own files)");
}

class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      if (fd_ >= 0) ::close(fd_);
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_ = -1;
};

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::vector<std::shared_ptr<Entry>>& registry() {
  static std::vector<std::shared_ptr<Entry>> held;
  return held;
}

std::filesystem::path normal_absolute(const std::filesystem::path& p) {
  std::filesystem::path n = std::filesystem::absolute(p).lexically_normal();
  if (!n.has_filename() && n.has_parent_path() && n != n.root_path()) n = n.parent_path();
  return n;
}

// The names of `p` below `root`, when `p` lies beneath it.
std::optional<std::vector<std::string>> names_below(const std::filesystem::path& root,
                                                    const std::filesystem::path& p) {
  auto r = root.begin();
  auto q = p.begin();
  for (; r != root.end(); ++r, ++q) {
    if (q == p.end() || *r != *q) return std::nullopt;
  }
  std::vector<std::string> names;
  for (; q != p.end(); ++q) {
    if (!q->empty() && *q != ".") names.push_back(q->string());
  }
  return names;
}

struct Beneath {
  std::shared_ptr<Entry> root;
  std::vector<std::string> names;  // of the path below the root, empty for the root itself
};

// The innermost held run directory `p` lies beneath, if any.
Beneath held_root_of(const std::filesystem::path& p) {
  const std::filesystem::path n = normal_absolute(p);
  Beneath best;
  std::lock_guard<std::mutex> lock(registry_mutex());
  for (const auto& e : registry()) {
    if (best.root && best.root->root.native().size() >= e->root.native().size()) continue;
    if (auto names = names_below(e->root, n)) best = {e, std::move(*names)};
  }
  return best;
}

// Runs `write`; a failure beneath a held run directory is kept there before it is thrown on.
template <class F>
void noting_failure(const Beneath& b, F&& write) {
  try {
    write();
  } catch (const std::exception& e) {
    if (b.root) b.root->note(e.what());
    throw;
  }
}

// One directory below `parent`, never a link; made first when missing and `create`.
Fd open_subdirectory(int parent, const std::string& name, bool create,
                     const std::filesystem::path& shown) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int fd = ::openat(parent, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd >= 0) return Fd(fd);
    const int err = errno;
    struct stat st {};
    if (::fstatat(parent, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode)) {
      throw link_refused(shown);
    }
    if (err != ENOENT || !create) throw failure("cannot open the directory", shown, err);
    if (::mkdirat(parent, name.c_str(), 0755) != 0 && errno != EEXIST) {
      throw failure("cannot create the directory", shown, errno);
    }
  }
  throw failure("cannot open the directory", shown, ENOENT);
}

// Where a run file goes: its directory, open, and its name there. Beneath a held run
// directory every name on the way is opened from the held descriptor without following a
// link; elsewhere (a tool writing a file of its own) the directory is opened as named.
struct Located {
  Fd dir;
  std::string name;
};

Located locate(const std::filesystem::path& file, const Beneath& b, bool create_dirs) {
  if (b.root) {
    if (b.names.empty()) throw failure("cannot write", file, EISDIR);
    Fd dir(::fcntl(b.root->fd, F_DUPFD_CLOEXEC, 0));
    if (dir.get() < 0) throw failure("cannot open the directory", b.root->root, errno);
    std::filesystem::path shown = b.root->root;
    for (std::size_t i = 0; i + 1 < b.names.size(); ++i) {
      shown /= b.names[i];
      dir = open_subdirectory(dir.get(), b.names[i], create_dirs, shown);
    }
    return {std::move(dir), b.names.back()};
  }
  const std::filesystem::path parent =
      file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
  if (create_dirs) {
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
  }
  const int fd = ::open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw failure("cannot write", file, errno);
  return {Fd(fd), file.filename().string()};
}

bool is_link_at(int dir, const std::string& name) {
  struct stat st {};
  return ::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode);
}

void write_all(int fd, std::string_view bytes, const std::filesystem::path& file) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw failure("cannot write", file, errno);
    }
    written += static_cast<std::size_t>(n);
  }
}

// The length of the file up to and including its last newline (0 when it has none).
off_t whole_lines_length(int fd, off_t size, const std::filesystem::path& file) {
  char buf[4096];
  off_t end = size;
  while (end > 0) {
    const off_t start = std::max<off_t>(0, end - static_cast<off_t>(sizeof buf));
    const ssize_t n = ::pread(fd, buf, static_cast<std::size_t>(end - start), start);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw failure("cannot read", file, errno);
    }
    if (n == 0) break;
    for (ssize_t i = n; i > 0; --i) {
      if (buf[i - 1] == '\n') return start + i;
    }
    end = start;
  }
  return 0;
}

}  // namespace

HeldRunDirectory::HeldRunDirectory(const std::filesystem::path& dir)
    : entry_(std::make_shared<Entry>()) {
  entry_->root = normal_absolute(dir);
  entry_->fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (entry_->fd < 0) throw failure("cannot open the directory", dir, errno);
  std::lock_guard<std::mutex> lock(registry_mutex());
  registry().push_back(entry_);
}

HeldRunDirectory::~HeldRunDirectory() {
  {
    std::lock_guard<std::mutex> lock(registry_mutex());
    auto& held = registry();
    held.erase(std::remove(held.begin(), held.end(), entry_), held.end());
  }
  ::close(entry_->fd);
}

int HeldRunDirectory::fd() const {
  return entry_->fd;
}

std::string HeldRunDirectory::first_failure() const {
  std::lock_guard<std::mutex> lock(entry_->mutex);
  return entry_->failure;
}

namespace {

void write_run_file_with_mode(const std::filesystem::path& file, std::string_view bytes,
                              mode_t mode) {
  const Beneath b = held_root_of(file);
  noting_failure(b, [&] {
    const Located at = locate(file, b, false);
    if (is_link_at(at.dir.get(), at.name)) throw link_refused(file);
    // Unique per process and call: two writers of one file (the watchdog's and the tick loop's)
    // never share a temporary, and O_EXCL refuses a planted one.
    static std::atomic<unsigned> serial{0};
    const std::string tmp =
        at.name + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(serial.fetch_add(1));
    const std::filesystem::path tmp_shown = file.parent_path() / tmp;
    Fd fd(::openat(at.dir.get(), tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC,
                   mode));
    if (fd.get() < 0) throw failure("cannot write", tmp_shown, errno);
    const auto fail = [&](const std::string& what, int err) {
      ::unlinkat(at.dir.get(), tmp.c_str(), 0);
      return failure(what, tmp_shown, err);
    };
    try {
      write_all(fd.get(), bytes, tmp_shown);
    } catch (...) {
      ::unlinkat(at.dir.get(), tmp.c_str(), 0);
      throw;
    }
    if (::fsync(fd.get()) != 0) throw fail("cannot flush", errno);
    if (::close(fd.release()) != 0) throw fail("cannot flush", errno);
    // renameat replaces a link at `file` rather than following it; the check above makes one
    // an error all the same, for the person who planted it to hear of.
    if (::renameat(at.dir.get(), tmp.c_str(), at.dir.get(), at.name.c_str()) != 0) {
      const int err = errno;
      ::unlinkat(at.dir.get(), tmp.c_str(), 0);
      throw std::runtime_error("cannot rename " + tmp_shown.string() + " to " + file.string() +
                               ": " + std::strerror(err));
    }
  });
}

}  // namespace

void write_run_file(const std::filesystem::path& file, std::string_view bytes) {
  write_run_file_with_mode(file, bytes, 0644);
}

void write_private_run_file(const std::filesystem::path& file, std::string_view bytes) {
  // Created 0600 (the umask can only take away): never readable by others, not even briefly.
  write_run_file_with_mode(file, bytes, 0600);
}

void make_run_directory(const std::filesystem::path& dir) {
  const Beneath b = held_root_of(dir);
  noting_failure(b, [&] {
    if (b.root && b.names.empty()) return;  // the held directory itself
    const Located at = locate(dir, b, true);
    open_subdirectory(at.dir.get(), at.name, true, dir);
  });
}

AppendOnlyFile::AppendOnlyFile(const std::filesystem::path& file) : file_(file) {
  const Beneath b = held_root_of(file);
  noting_failure(b, [&] {
    const Located at = locate(file, b, false);
    // O_NONBLOCK: a FIFO planted as the log must be refused, not waited on for a reader.
    Fd fd(::openat(at.dir.get(), at.name.c_str(),
                   O_RDWR | O_CREAT | O_APPEND | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0644));
    if (fd.get() < 0) {
      if (errno == ELOOP) throw link_refused(file);
      throw failure("cannot open", file, errno);
    }
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) throw failure("cannot open", file, errno);
    if (!S_ISREG(st.st_mode)) {
      throw std::runtime_error("refusing to append to " + file.string() +
                               ": not a regular file (a run directory holds only the run's own "
                               "files)");
    }
    if (st.st_nlink != 1) {
      throw std::runtime_error("refusing to append to " + file.string() +
                               ": it has another hard link, so writing it would change a file "
                               "outside the run");
    }
    const off_t whole = whole_lines_length(fd.get(), st.st_size, file);
    if (whole != st.st_size && ::ftruncate(fd.get(), whole) != 0) {
      throw failure("cannot cut the partial last line of", file, errno);
    }
    fd_ = fd.release();
  });
}

AppendOnlyFile::~AppendOnlyFile() {
  if (fd_ >= 0) ::close(fd_);
}

AppendOnlyFile::AppendOnlyFile(AppendOnlyFile&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), file_(std::move(other.file_)) {}

AppendOnlyFile& AppendOnlyFile::operator=(AppendOnlyFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    file_ = std::move(other.file_);
  }
  return *this;
}

void AppendOnlyFile::append(std::string_view bytes) {
  noting_failure(held_root_of(file_), [&] {
    if (fd_ < 0) throw std::runtime_error("cannot write " + file_.string() + ": not open");
    struct stat st {};
    if (::fstat(fd_, &st) != 0) throw failure("cannot write", file_, errno);
    try {
      write_all(fd_, bytes, file_);
    } catch (...) {
      // Half a line would stay in the log for every reader to trip on.
      if (::ftruncate(fd_, st.st_size) != 0) {
        // The failure being thrown is the one to report.
      }
      throw;
    }
  });
}

}  // namespace projtour
