// The projector-safety check every integration test relies on, on hand-written run directories:
// it must flag what it is there to catch, or the integration tests would pass vacuously.
#include <gtest/gtest.h>

#include <fstream>

#include "dry_run.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::integration {
namespace {

class ProjectorSafety : public ::testing::Test {
 protected:
  std::vector<std::string> problems(const std::string& log) {
    std::ofstream(dir_ / "sim_projector_log.jsonl") << log;
    return projector_safety_problems(dir_.path(), events_);
  }

  test::TempDir dir_;
  // A visit whose project state ran from 10 s to 12 s.
  std::vector<Json> events_ = {
      parse_json(R"({"t": 10.0, "event": "enter", "state": "tour/visit/project", "target": "a"})",
                 "event"),
      parse_json(R"({"t": 12.0, "event": "exit", "state": "tour/visit/project", "target": "a"})",
                 "event"),
  };
};

std::string line(double t_s, const char* event, bool base_moving, bool head_moving) {
  return std::string("{\"t\": ") + json_number_text(t_s) + ", \"event\": \"" + event +
         "\", \"base_moving\": " + (base_moving ? "true" : "false") +
         ", \"head_moving\": " + (head_moving ? "true" : "false") + ", \"target\": \"a\"}\n";
}

TEST_F(ProjectorSafety, ALitSpellInsideProjectWithEverythingStillIsSafe) {
  EXPECT_TRUE(problems(line(0, "blank", true, false) + line(10.05, "show", false, false) +
                       line(12, "blank", false, false))
                  .empty());
}

TEST_F(ProjectorSafety, FlagsShowingWhileTheBaseMoves) {
  EXPECT_EQ(problems(line(10.05, "show", true, false) + line(12, "blank", false, false)).size(),
            1u);
}

TEST_F(ProjectorSafety, FlagsBlankingOnlyAfterTheHeadStartedMoving) {
  EXPECT_EQ(problems(line(10.05, "show", false, false) + line(12, "blank", false, true)).size(),
            1u);
}

TEST_F(ProjectorSafety, FlagsLightOutsideProject) {
  EXPECT_EQ(problems(line(9, "show", false, false) + line(11, "blank", false, false)).size(), 1u);
}

TEST_F(ProjectorSafety, FlagsAProjectorLeftLit) {
  EXPECT_EQ(problems(line(10.05, "show", false, false)).size(), 1u);
}

TEST_F(ProjectorSafety, ACutLineIsAnError) {
  EXPECT_THROW(problems(line(10.05, "show", false, false) + "{\"t\": 12"), std::runtime_error);
}

}  // namespace
}  // namespace projtour::integration
