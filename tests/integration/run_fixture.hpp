#pragma once
// A GoogleTest fixture giving each test its own scratch directory and one-call dry runs of the
// integration mission.
#include <gtest/gtest.h>

#include <optional>

#include "dry_run.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::integration {

struct DryRunResult {
  int exit_code = -1;
  fs::path dir;
  Json report;
  std::vector<Json> events;
  std::string err;
};

class DryRunTest : public ::testing::Test {
 protected:
  void SetUp() override;
  void TearDown() override;

  // Runs the mission `mission_` (default short_tour.yaml) in `world`, both files in data/, into
  // dir_/name.
  // Fails the test when the run directory holds an unparsable file or the projector was lit
  // while something moved.
  DryRunResult dry_run(const std::string& world, const std::string& name,
                       const std::vector<std::string>& extra = {});

  std::optional<test::TempDir> scratch_;  // kept when the test failed
  fs::path dir_;
  std::string mission_ = "short_tour.yaml";
};

}  // namespace projtour::integration
