#pragma once
// The run directory belongs to one run: claimed before anything is written, locked for the
// run's life, and refused when it already holds another run's files.
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "projtour/contract/run_files.hpp"

namespace projtour {

// Why a directory cannot be this run's (exit 2: nothing was written, nothing moved).
struct RunDirectoryError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class RunDirectory {
 public:
  // `out`: the --out directory, or none for a fresh runs/<mission>-<YYYYmmdd-HHMMSS>[-N] (N from
  // 2 when runs start in the same second). Without `resume` the directory must be new or empty
  // (and is left as it was when it is not); with it, it must hold no symbolic link anywhere
  // (a planted link would be written through). Either way it is held open and locked (flock on
  // the directory itself; `.lock` names the holder's pid) until this object is gone or the
  // process ends, however it ends. An `out` that is a link to a directory is followed once,
  // here; nothing beneath it is ever reached through a link.
  static RunDirectory claim(const std::optional<std::filesystem::path>& out, bool resume,
                            const std::string& mission_name);
  RunDirectory(RunDirectory&& other) noexcept;
  RunDirectory& operator=(RunDirectory&&) = delete;
  RunDirectory(const RunDirectory&) = delete;
  ~RunDirectory();

  const std::filesystem::path& path() const { return path_; }
  // The first run file beneath the directory that could not be written, with the reason (a
  // planted link, a full disk), whoever was writing it; "" while none.
  std::string first_write_failure() const;

 private:
  RunDirectory(std::filesystem::path path, std::unique_ptr<HeldRunDirectory> held);
  std::filesystem::path path_;
  std::unique_ptr<HeldRunDirectory> held_;
};

}  // namespace projtour
