#pragma once
// Fixture files written into a fresh temporary directory per test, so every path and every
// line and column in an expected diagnostic is exact.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <optional>

#include <filesystem>
#include <string>
#include <vector>

#include "projtour/host/diagnostics.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::test {

// Line numbers matter: tests replace text in these and expect diagnostics at known places.
extern const char* const kMission;
extern const char* const kRobot;

// `text` with the first occurrence of `from` replaced (which must occur).
std::string replace(std::string text, const std::string& from, const std::string& to);
// Every diagnostic, formatted, in order.
std::vector<std::string> formatted(const host::Diagnostics& diag);

class LoaderTest : public ::testing::Test {
 protected:
  void SetUp() override;
  void TearDown() override;

  // Writes `text` to dir/name (making directories) and returns the full path.
  std::string write(const std::string& name, const std::string& text) const;
  // Loads a mission written as dir/m.yaml; expects it to fail and returns the diagnostics.
  std::vector<std::string> mission_errors(const std::string& text) const;
  std::vector<std::string> robot_errors(const std::string& text) const;

  std::optional<TempDir> scratch_;  // kept when the test failed
  std::filesystem::path dir_path;
  std::string dir;  // dir_path as a string, for building expected messages
};

}  // namespace projtour::test
