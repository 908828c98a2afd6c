#pragma once
// Files a run writes into its run directory, for the executor and the plugins alike. None of
// them is written through a symbolic link: a link someone planted in a run directory (which
// the run may write as root) is an error naming it, never a write to where it points. A write
// that fails -- a full disk, a file-size limit -- throws with the file and the system's reason,
// so that no caller can lose a file without a word.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace projtour {

// The run directory, held open for the run's life by whoever claimed it (the executor). Run
// files beneath a held directory are reached from its descriptor one name at a time, none
// through a symbolic link, so a link planted while the run goes on (targets/<id> replaced by a
// link to /etc) is refused, naming it, instead of written through. The directory itself is
// resolved once, when held: an --out that is a link to a directory was the user's own choice,
// made before the run began.
//
// The first failure of any run file beneath it (a refused link, a full disk) is kept: the run
// ends failed on it even when the writer -- a plugin drawing a picture -- only warned.
class HeldRunDirectory {
 public:
  explicit HeldRunDirectory(const std::filesystem::path& dir);  // throws std::runtime_error
  ~HeldRunDirectory();
  HeldRunDirectory(const HeldRunDirectory&) = delete;
  HeldRunDirectory& operator=(const HeldRunDirectory&) = delete;

  // Open for this object's life (the run's lock is taken on it).
  int fd() const;
  // The first run file that failed beneath the directory, with the reason; "" while none has.
  std::string first_failure() const;

  struct Entry;

 private:
  std::shared_ptr<Entry> entry_;
};

// The whole file at once: written to a temporary file beside `file` (created exclusively,
// never through a link), flushed and fsync'ed, then renamed over `file`, so a reader never sees
// half a file. `file` itself may not be a symbolic link. Throws std::runtime_error.
void write_run_file(const std::filesystem::path& file, std::string_view bytes);
// write_run_file for a secret (the monitor's control token): readable by its owner only.
void write_private_run_file(const std::filesystem::path& file, std::string_view bytes);

// `dir` and any missing parents. `dir` itself must end up a real directory: a symbolic link
// there throws std::runtime_error naming it (the run directory was searched for links when the
// run claimed it; this keeps a link planted since then from being written through).
void make_run_directory(const std::filesystem::path& dir);

// A log of lines that only grows: opened with O_APPEND (created if missing, never through a
// link; a FIFO, a device or a file with another hard link is refused), each append written
// whole or throwing. A resumed run continues the file; a last line left partial (a full disk,
// a kill mid-write) is cut off first, so that every line stays whole. An append that fails is
// undone to the file's length before it.
class AppendOnlyFile {
 public:
  AppendOnlyFile() = default;
  explicit AppendOnlyFile(const std::filesystem::path& file);  // throws std::runtime_error
  ~AppendOnlyFile();
  AppendOnlyFile(AppendOnlyFile&& other) noexcept;
  AppendOnlyFile& operator=(AppendOnlyFile&& other) noexcept;
  AppendOnlyFile(const AppendOnlyFile&) = delete;
  AppendOnlyFile& operator=(const AppendOnlyFile&) = delete;

  bool is_open() const { return fd_ >= 0; }
  const std::filesystem::path& path() const { return file_; }
  void append(std::string_view bytes);  // throws std::runtime_error

 private:
  int fd_ = -1;
  std::filesystem::path file_;
};

}  // namespace projtour
