#pragma once
// Files a run writes into its run directory, for the executor and the plugins alike. None of
// them is written through a symbolic link: a link someone planted in a run directory (which
// the run may write as root) is an error naming it, never a write to where it points. A write
// that fails -- a full disk, a file-size limit -- throws with the file and the system's reason,
// so that no caller can lose a file without a word.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace projtour {

// The whole file at once: written to a temporary file beside `file` (created exclusively,
// never through a link), flushed and fsync'ed, then renamed over `file`, so a reader never sees
// half a file. `file` itself may not be a symbolic link. Throws std::runtime_error.
void write_run_file(const std::filesystem::path& file, std::string_view bytes);

// `dir` and any missing parents. `dir` itself must end up a real directory: a symbolic link
// there throws std::runtime_error naming it (the run directory was searched for links when the
// run claimed it; this keeps a link planted since then from being written through).
void make_run_directory(const std::filesystem::path& dir);

// A log that only grows: opened with O_APPEND (created if missing, never truncated, never
// through a link), each append written whole or throwing. A resumed run continues the file.
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
