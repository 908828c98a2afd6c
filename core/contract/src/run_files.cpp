#include "projtour/run_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace projtour {
namespace {

std::runtime_error failure(const std::string& what, const std::filesystem::path& file, int err) {
  return std::runtime_error(what + " " + file.string() + ": " + std::strerror(err));
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

bool is_link(const std::filesystem::path& p) {
  struct stat st {};
  return ::lstat(p.c_str(), &st) == 0 && S_ISLNK(st.st_mode);
}

}  // namespace

void write_run_file(const std::filesystem::path& file, std::string_view bytes) {
  if (is_link(file)) throw failure("refusing to write through the symbolic link", file, ELOOP);
  // Unique per process and call: two writers of one file (the watchdog's and the tick loop's)
  // never share a temporary, and O_EXCL refuses a planted one.
  static std::atomic<unsigned> serial{0};
  const std::filesystem::path tmp = file.string() + ".tmp." + std::to_string(::getpid()) + "." +
                                    std::to_string(serial.fetch_add(1));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw failure("cannot write", tmp, errno);
  try {
    write_all(fd, bytes, tmp);
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw failure("cannot flush", tmp, err);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw failure("cannot flush", tmp, err);
  }
  // rename replaces a link at `file` rather than following it; the check above makes one an
  // error all the same, for the person who planted it to hear of.
  if (std::rename(tmp.c_str(), file.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot rename " + tmp.string() + " to " + file.string() + ": " +
                             std::strerror(err));
  }
}

void make_run_directory(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0) throw failure("cannot create the directory", dir, errno);
  if (S_ISLNK(st.st_mode)) throw failure("refusing to write through the symbolic link", dir, ELOOP);
  if (!S_ISDIR(st.st_mode)) throw failure("cannot create the directory", dir, ENOTDIR);
}

AppendOnlyFile::AppendOnlyFile(const std::filesystem::path& file) : file_(file) {
  fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw failure(errno == ELOOP ? "refusing to write through the symbolic link" : "cannot open",
                  file, errno);
  }
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
  if (fd_ < 0) throw std::runtime_error("cannot write " + file_.string() + ": not open");
  write_all(fd_, bytes, file_);
}

}  // namespace projtour
