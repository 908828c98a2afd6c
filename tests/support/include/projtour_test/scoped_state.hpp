#pragma once
// Process-wide state a test changes and must put back: the tests of a binary may all run in one
// process (running the binary by hand), not only one per process as ctest runs them.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace projtour::test {

// Sets (or with nullptr, removes) an environment variable for the scope.
class ScopedEnv {
 public:
  ScopedEnv(const std::string& name, const char* value);
  ~ScopedEnv();
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

// Changes the current directory for the scope.
class ScopedCurrentPath {
 public:
  explicit ScopedCurrentPath(const std::filesystem::path& dir);
  ~ScopedCurrentPath();
  ScopedCurrentPath(const ScopedCurrentPath&) = delete;
  ScopedCurrentPath& operator=(const ScopedCurrentPath&) = delete;

 private:
  std::filesystem::path old_;
};

// Whether the file is mapped into this process (/proc/self/maps names it): what is really there,
// whatever the dynamic linker's bookkeeping says.
bool mapped_in_this_process(const std::filesystem::path& file);

}  // namespace projtour::test
