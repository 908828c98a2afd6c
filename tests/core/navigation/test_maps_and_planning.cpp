// Occupancy grids (ROS map_server YAML, MRPT gridmaps), stand-off poses, validation against the
// map with exact diagnostics, and planning on the inflated grid.
#include <gtest/gtest.h>
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "demo_map_crop.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/navigation/path_planner.hpp"
#include "projtour/tour/runner.hpp"
#include "projtour_test/temp_dir.hpp"
#include "projtour_test/test_maps.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;
const std::string kDemoMap = PROJTOUR_SOURCE_DIR "/maps/malaga_campus.yaml";
const std::string kMalagaSource = "/usr/share/mrpt/datasets/2006-MalagaCampus.gridmap.gz";

fs::path temp_dir(const std::string& name) {
  const fs::path dir = test::scratch_dir() / name;
  fs::create_directories(dir);
  return dir;
}

TEST(OccupancyGrid, LoadsRosMapServerYamlWithPgm) {
  const fs::path dir = temp_dir("pgm");
  // 4 x 2 pixels: top row black (occupied), white (free), 205 (unknown), white; bottom row white.
  {
    std::ofstream pgm(dir / "tiny.pgm", std::ios::binary);
    pgm << "P5\n4 2\n255\n";
    const unsigned char pixels[8] = {0, 254, 205, 255, 255, 255, 255, 255};
    pgm.write(reinterpret_cast<const char*>(pixels), 8);
    std::ofstream yaml(dir / "tiny.yaml");
    yaml << "image: tiny.pgm\nresolution: 0.5\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  }
  const auto map = navigation::load_occupancy_grid(dir / "tiny.yaml");
  ASSERT_EQ(map->getSizeX(), 4u);
  ASSERT_EQ(map->getSizeY(), 2u);
  EXPECT_FLOAT_EQ(map->getXMin(), -1.0f);
  EXPECT_FLOAT_EQ(map->getYMin(), 2.0f);
  EXPECT_FLOAT_EQ(map->getResolution(), 0.5f);
  // Image row 0 is the top: cell row 1.
  EXPECT_LT(map->getCell(0, 1), 0.1f);
  EXPECT_GT(map->getCell(1, 1), 0.9f);
  EXPECT_NEAR(map->getCell(2, 1), 0.5f, 0.05f);
  EXPECT_GT(map->getCell(0, 0), 0.9f);
}

TEST(OccupancyGrid, LoadsMrptGridmapGz) {
  const auto map = navigation::load_occupancy_grid(kMalagaSource);
  EXPECT_EQ(map->getSizeX(), 1888u);
  EXPECT_EQ(map->getSizeY(), 2738u);
  EXPECT_FLOAT_EQ(map->getResolution(), 0.08f);
}

TEST(OccupancyGrid, ErrorsNameTheFile) {
  try {
    navigation::load_occupancy_grid("/nonexistent/atrium.yaml");
    FAIL() << "expected a throw";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/atrium.yaml: no such map file");
  }
  const fs::path dir = temp_dir("bad");
  std::ofstream(dir / "bad.yaml") << "image: missing.png\nresolution: fine\norigin: [0, 0, 0]\n";
  try {
    navigation::load_occupancy_grid(dir / "bad.yaml");
    FAIL() << "expected a throw";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "bad.yaml").string() + ":2:13: resolution: expected a number");
  }
}

// The first message of load_occupancy_grid on `yaml` beside a 2 x 2 PGM, or "" when it loads.
std::string map_error(const std::string& name, const std::string& yaml) {
  const fs::path dir = temp_dir(name);
  std::ofstream(dir / "tiny.pgm", std::ios::binary) << "P5\n2 2\n255\n" << std::string(4, '\xff');
  std::ofstream(dir / "map.yaml") << yaml;
  try {
    navigation::load_occupancy_grid(dir / "map.yaml");
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    const std::string prefix = (dir / "map.yaml").string();
    return what.rfind(prefix, 0) == 0 ? "map.yaml" + what.substr(prefix.size()) : what;
  }
  return "";
}

TEST(OccupancyGrid, DuplicateKeyInAMapFileRefused) {
  EXPECT_EQ(map_error("duplicate",
                      "image: tiny.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nresolution: 5\n"),
            "map.yaml:4:1: resolution: duplicate key \"resolution\" (first at line 2)");
}

TEST(OccupancyGrid, ThresholdsInTheWrongOrderRefused) {
  const std::string head = "image: tiny.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
  EXPECT_EQ(map_error("thresholds", head + "occupied_thresh: 0.2\nfree_thresh: 0.6\n"),
            "map.yaml:4:18: occupied_thresh: expected free_thresh < occupied_thresh, got "
            "free_thresh 0.6 and occupied_thresh 0.2");
  EXPECT_EQ(map_error("free_negative", head + "free_thresh: -0.1\n"),
            "map.yaml:4:14: free_thresh: must be >= 0");
  EXPECT_EQ(map_error("occupied_above_one", head + "occupied_thresh: 1.5\n"),
            "map.yaml:4:18: occupied_thresh: must be <= 1");
  EXPECT_EQ(map_error("thresholds_fine", head + "occupied_thresh: 1\nfree_thresh: 0\n"), "");
}

TEST(OccupancyGrid, NonFiniteResolutionAndOriginRefused) {
  EXPECT_EQ(map_error("resolution_inf", "image: tiny.pgm\nresolution: .inf\norigin: [0, 0, 0]\n"),
            "map.yaml:2:13: resolution: expected a number");
  EXPECT_EQ(map_error("origin_nan", "image: tiny.pgm\nresolution: 0.05\norigin: [0, .nan, 0]\n"),
            "map.yaml:3:13: origin[1]: expected a number");
}

// 100 million cells is the bound: one pixel more is refused before the grid is made.
TEST(OccupancyGrid, ImageAboveTheCellBoundRefused) {
  const fs::path dir = temp_dir("huge");
  ASSERT_TRUE(cv::imwrite((dir / "huge.png").string(), cv::Mat(10000, 10001, CV_8UC1, 255)));
  std::ofstream(dir / "map.yaml") << "image: huge.png\nresolution: 0.05\norigin: [0, 0, 0]\n";
  try {
    navigation::load_occupancy_grid(dir / "map.yaml");
    FAIL() << "expected a throw";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "map.yaml").string() +
                                         ":1:8: image: the image is 10001 x 10000 pixels; a map "
                                         "has at most 100000000 cells");
  }
}

TEST(OccupancyGrid, SavedYamlReadsBackCellForCell) {
  const auto dir = temp_dir("roundtrip");
  const auto file = nav_test::write_corridor_map(dir);
  const auto map = navigation::load_occupancy_grid(file);
  navigation::save_occupancy_grid_yaml(*map, dir / "again.yaml");
  const auto again = navigation::load_occupancy_grid(dir / "again.yaml");
  ASSERT_EQ(map->getSizeX(), again->getSizeX());
  ASSERT_EQ(map->getSizeY(), again->getSizeY());
  for (unsigned y = 0; y < map->getSizeY(); ++y) {
    for (unsigned x = 0; x < map->getSizeX(); ++x) {
      ASSERT_NEAR(map->getCell(x, y), again->getCell(x, y), 0.02f) << x << "," << y;
    }
  }
}

TEST(DemoMap, MatchesItsSource) {
  const auto committed = navigation::load_occupancy_grid(kDemoMap);
  const auto regenerated =
      demo_map::crop_and_classify(*navigation::load_occupancy_grid(kMalagaSource));
  ASSERT_EQ(committed->getSizeX(), regenerated.getSizeX());
  ASSERT_EQ(committed->getSizeY(), regenerated.getSizeY());
  EXPECT_FLOAT_EQ(committed->getXMin(), demo_map::kXMinM);
  EXPECT_FLOAT_EQ(committed->getYMin(), demo_map::kYMinM);
  std::size_t differing = 0;
  for (unsigned y = 0; y < committed->getSizeY(); ++y) {
    for (unsigned x = 0; x < committed->getSizeX(); ++x) {
      if (std::abs(committed->getCell(x, y) - regenerated.getCell(x, y)) > 0.1f) ++differing;
    }
  }
  EXPECT_EQ(differing, 0u);
}

TEST(StandoffPose, IsInFrontOfTheTargetFacingIt) {
  TargetSpec target;
  target.T_map_model = isometry_from_xyz_rpy(6.0, 2.0, 0.9, 0.0, 0.0, kPi);  // faces -x
  target.standoff_m = 1.5;
  const Pose2D p = navigation::standoff_pose(target);
  EXPECT_NEAR(p.x_m, 4.5, 1e-9);
  EXPECT_NEAR(p.y_m, 2.0, 1e-9);
  EXPECT_NEAR(wrap_angle_rad(p.yaw_rad), 0.0, 1e-9);
  // A tilted model: only the floor projection of +x counts.
  target.T_map_model = isometry_from_xyz_rpy(0.0, 0.0, 1.0, 0.0, -0.5, kPi / 2);
  const Pose2D q = navigation::standoff_pose(target);
  EXPECT_NEAR(q.x_m, 0.0, 1e-9);
  EXPECT_NEAR(q.y_m, 1.5, 1e-9);
  EXPECT_NEAR(q.yaw_rad, -kPi / 2, 1e-9);
}

// A mission on the corridor map with marks as the loader would record them.
host::LoadedMission corridor_mission() {
  host::LoadedMission m;
  m.file = "m.yaml";
  m.robot.base.radius_m = 0.35;
  m.start = Pose2D{3.0, 2.0, 0.0};
  m.marks["start"] = host::SourceMark{"m.yaml", 3, 8};
  auto add = [&](double x, double y, double yaw, int line) {
    TargetSpec t;
    t.id = "t" + std::to_string(m.targets.size());
    t.T_map_model = isometry_from_xyz_rpy(x, y, 1.0, 0.0, 0.0, yaw);
    const std::string prefix = "targets[" + std::to_string(m.targets.size()) + "]";
    m.marks[prefix + ".pose"] = host::SourceMark{"m.yaml", line, 11};
    m.marks[prefix + ".standoff_m"] = host::SourceMark{"m.yaml", line + 1, 17};
    m.targets.push_back(t);
  };
  add(20.0, 3.2, -kPi / 2, 10);  // on the corridor's wall, facing into it: fine
  add(12.0, 11.5, kPi / 2, 20);  // stand-off at (12, 12.5): outside the map
  add(40.0, 2.0, kPi, 30);       // off the map
  add(12.0, 5.0, -kPi / 2, 40);  // stand-off (12, 4): in the unknown between corridor and room
  add(5.0, 1.95, -kPi / 2, 50);  // stand-off (5, 0.95) in the corridor's wall
  add(12.0, 7.0, kPi / 2, 60);   // stand-off (12, 8): inside the closed room
  add(20.0, 1.8, kPi / 2, 70);   // stand-off (20, 2.8): free, but 0.2 m from the wall
  return m;
}

TEST(ValidateAgainstMap, ReportsEachProblemAtItsField) {
  const auto map =
      navigation::load_occupancy_grid(nav_test::write_corridor_map(temp_dir("validate")));
  host::Diagnostics diag;
  const host::LoadedMission mission = corridor_mission();
  report_map_problems(mission, navigation::check_mission_on_map(mission, *map), diag);
  std::vector<std::string> lines;
  for (const auto& d : diag.items()) lines.push_back(d.format());
  const std::vector<std::string> expected = {
      "m.yaml:21:17: targets[1].standoff_m: stand-off pose (12.00, 12.50) is outside the map",
      "m.yaml:30:11: targets[2].pose: target (40.00, 2.00) is outside the map (x 0.00..30.00, y "
      "0.00..12.00)",
      "m.yaml:41:17: targets[3].standoff_m: stand-off pose (12.00, 4.00) is in an unknown cell",
      "m.yaml:51:17: targets[4].standoff_m: stand-off pose (5.00, 0.95) is in an occupied cell",
      "m.yaml:61:17: targets[5].standoff_m: stand-off pose (12.00, 8.00) is not reachable from "
      "the start",
      "m.yaml:71:17: targets[6].standoff_m: stand-off pose (20.00, 2.80) is closer than the "
      "robot's radius (0.35 m) to an obstacle",
  };
  EXPECT_EQ(lines, expected);
}

TEST(ValidateAgainstMap, StartInAWall) {
  const auto map = navigation::load_occupancy_grid(nav_test::write_corridor_map(temp_dir("start")));
  host::LoadedMission m = corridor_mission();
  m.targets.resize(1);
  m.start = Pose2D{3.0, 0.95, 0.0};
  host::Diagnostics diag;
  report_map_problems(m, navigation::check_mission_on_map(m, *map), diag);
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "m.yaml:3:8: start: start pose (3.00, 0.95) is in an occupied cell");
}

TEST(PathPlanner, PathsOnTheDemoMapAreCollisionFreeOnTheInflatedGrid) {
  const auto map = navigation::load_occupancy_grid(kDemoMap);
  const navigation::PathPlanner planner(*map, 0.35);
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> queries = {
      {{10.0, 1.0}, {30.0, 1.0}},
      {{10.0, 1.0}, {22.0, -100.0}},
      {{-5.0, -50.0}, {42.0, -20.0}},
      {{42.0, -110.0}, {22.0, 5.0}}};
  for (const auto& [start, goal] : queries) {
    const auto path = planner.plan(start, goal);
    ASSERT_TRUE(path.has_value()) << start.transpose() << " -> " << goal.transpose();
    EXPECT_EQ(path->points_m.front(), start);
    EXPECT_EQ(path->points_m.back(), goal);
    EXPECT_GE(path->length_m, (goal - start).norm() - 1e-9);
    for (std::size_t i = 1; i < path->points_m.size(); ++i) {
      ASSERT_TRUE(planner.grid().segment_fits(path->points_m[i - 1], path->points_m[i]))
          << "segment " << i << " of " << start.transpose() << " -> " << goal.transpose();
    }
    EXPECT_NEAR(*planner.path_length_m(start, goal), path->length_m, 1e-9);
  }
}

TEST(PathPlanner, NoPathIntoAClosedRoomAndAroundNewObstacles) {
  const auto map =
      navigation::load_occupancy_grid(nav_test::write_corridor_map(temp_dir("planner")));
  navigation::PathPlanner planner(*map, 0.35);
  EXPECT_FALSE(planner.plan({3.0, 2.0}, {12.0, 8.0}).has_value());
  EXPECT_TRUE(planner.plan({3.0, 2.0}, {25.0, 2.0}).has_value());
  std::vector<Eigen::Vector2d> wall;
  for (double y = 1.0; y <= 3.0; y += 0.04) wall.emplace_back(12.0, y);
  planner.grid().add_obstacles(wall);
  EXPECT_FALSE(planner.plan({3.0, 2.0}, {25.0, 2.0}).has_value());
  EXPECT_FALSE(planner.reachable_from({3.0, 2.0}).contains({25.0, 2.0}));
  EXPECT_TRUE(planner.reachable_from({3.0, 2.0}).contains({8.0, 2.0}));
}

}  // namespace
}  // namespace projtour
