#pragma once
// Scratch directories for tests. ctest runs test cases in parallel processes and a whole binary
// runs them one after another in one process, so a name must differ per process and per test;
// and what a failed test leaves is what one wants to look at, so it is kept then.
#include <filesystem>
#include <string>

namespace projtour::test {

// "Suite.Name" of the running GoogleTest test (parameterised names included), "" outside one.
std::string current_test_name();

// A new empty directory under the system temp dir, named after the running test. Removed by the
// destructor, unless the running test has failed by then: then it stays and its path is printed
// to stderr.
class TempDir {
 public:
  // `tag` is added to the name (for a test that makes several).
  explicit TempDir(const std::string& tag = "");
  ~TempDir();
  TempDir(TempDir&& other) noexcept;
  TempDir& operator=(TempDir&& other) noexcept;
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::filesystem::path& child) const {
    return path_ / child;
  }
  // Kept even when the test passes (while debugging one).
  void keep() { keep_ = true; }

 private:
  void release();
  std::filesystem::path path_;
  bool keep_ = false;
};

// The running test's own scratch directory, made on first use and treated like a TempDir when
// the test ends (removed, or kept and printed when it failed): for helpers that hand out paths
// rather than objects. Outside a test it lasts until the process ends.
const std::filesystem::path& scratch_dir();

}  // namespace projtour::test
