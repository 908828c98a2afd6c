// Mission files: the values loaded from good input, and for bad input every diagnostic exactly
// (file, line, column, field path, message).
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "projtour/host/mission_loader.hpp"
#include "projtour_test/loader_fixture.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

class MissionLoader : public LoaderTest {};

// ---------------------------------------------------------------- good input

TEST_F(MissionLoader, FixtureLoadsWithAllValues) {
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("m.yaml", kMission), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_TRUE(diag.items().empty()) << diag.format();
  EXPECT_EQ(mission->name, "atrium-spring-sale");
  EXPECT_EQ(mission->file, dir + "/m.yaml");
  EXPECT_EQ(mission->map, dir_path / "map.yaml");
  EXPECT_EQ(mission->robot_file, dir_path / "robot.yaml");
  EXPECT_EQ(mission->robot.name, "test-bot");
  EXPECT_DOUBLE_EQ(mission->start.x_m, 1.0);
  EXPECT_DOUBLE_EQ(mission->start.y_m, 1.5);
  EXPECT_DOUBLE_EQ(mission->start.yaw_rad, kPi / 2);
  EXPECT_EQ(mission->order, "mission");
  EXPECT_TRUE(mission->machine.is_default);
  ASSERT_EQ(mission->targets.size(), 2u);

  const TargetSpec& rabbit = mission->targets[0];
  EXPECT_EQ(rabbit.id, "rabbit");
  EXPECT_EQ(rabbit.model, dir_path / "bunny.ply");
  EXPECT_EQ(rabbit.content, dir_path / "sale.png");
  EXPECT_TRUE(rabbit.T_map_model.translation().isApprox(Eigen::Vector3d(6.0, 2.0, 0.9)));
  // yaw 180: the model's front (+x) faces -x of the map.
  EXPECT_TRUE(
      (rabbit.T_map_model.linear() * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(rabbit.model_points[1].isApprox(Eigen::Vector3d(0.1215, 0.06, 0.08)));
  EXPECT_TRUE(rabbit.model_points[3].isApprox(Eigen::Vector3d(0.1153, 0.0, -0.02)));
  EXPECT_DOUBLE_EQ(rabbit.standoff_m, 1.2);
  EXPECT_DOUBLE_EQ(rabbit.dwell_s, 15.0);

  const TargetSpec& hare = mission->targets[1];
  EXPECT_EQ(hare.id, "hare");
  EXPECT_DOUBLE_EQ(hare.standoff_m, 1.0);  // defaults
  EXPECT_DOUBLE_EQ(hare.dwell_s, 10.0);
  EXPECT_DOUBLE_EQ(hare.tolerance_mm, 3.0);
  EXPECT_TRUE(
      (hare.T_map_model.linear() * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitY()));
}

TEST_F(MissionLoader, MarksPointAtEachField) {
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("m.yaml", kMission), diag);
  ASSERT_TRUE(mission) << diag.format();
  const std::string file = dir + "/m.yaml";
  auto at = [&](const std::string& field) {
    const host::SourceMark m = mission->mark_of(field);
    return m.file + ":" + std::to_string(m.line) + ":" + std::to_string(m.column);
  };
  EXPECT_EQ(at("mission"), file + ":1:10");
  EXPECT_EQ(at("map"), file + ":2:6");
  EXPECT_EQ(at("robot"), file + ":3:8");
  EXPECT_EQ(at("start"), file + ":4:8");
  EXPECT_EQ(at("targets"), file + ":6:3");
  EXPECT_EQ(at("targets[1]"), file + ":13:5");
  EXPECT_EQ(at("targets[1].id"), file + ":13:9");
  EXPECT_EQ(at("targets[0].model"), file + ":7:12");
  EXPECT_EQ(at("targets[0].pose"), file + ":8:11");
  EXPECT_EQ(at("targets[0].model_points"), file + ":9:19");
  EXPECT_EQ(at("targets[0].content"), file + ":10:14");
  EXPECT_EQ(at("targets[0].standoff_m"), file + ":11:17");
  // Absent optional fields point at their target.
  EXPECT_EQ(at("targets[1].standoff_m"), file + ":13:5");
  EXPECT_EQ(at("machine"), file + ":18:10");
}

TEST_F(MissionLoader, ToleranceIsReadPerTarget) {
  host::Diagnostics diag;
  const auto mission = host::load_mission(
      write("m.yaml", replace(kMission, "dwell_s: 15", "dwell_s: 15\n    tolerance_mm: 2.5")),
      diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_DOUBLE_EQ(mission->targets[0].tolerance_mm, 2.5);
  EXPECT_DOUBLE_EQ(mission->targets[1].tolerance_mm, TargetSpec{}.tolerance_mm);
  const host::SourceMark m = mission->mark_of("targets[0].tolerance_mm");
  EXPECT_EQ(m.line, 13);
  EXPECT_EQ(m.column, 19);
}

TEST_F(MissionLoader, RelativePathsResolveAgainstTheFileThatNamesThem) {
  // Mission, map, robot and assets in four different folders.
  write("maps/site.yaml", "image: site.pgm\nresolution: 0.05\n");
  write("robots/ud.yaml", kRobot);
  write("assets/models/bunny.ply", "ply\n");
  ASSERT_TRUE(cv::imwrite(dir + "/assets/sale.jpg", cv::Mat(4, 4, CV_8UC1, cv::Scalar(9))));
  // The second target keeps its plain names, which now mean files beside the mission.
  write("missions/bunny.ply", "ply\n");
  ASSERT_TRUE(cv::imwrite(dir + "/missions/sale.png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(9))));
  std::string text = replace(kMission, "map: map.yaml", "map: ../maps/site.yaml");
  text = replace(text, "robot: robot.yaml", "robot: ../robots/ud.yaml");
  text = replace(text, "model: bunny.ply", "model: ../assets/models/bunny.ply");
  text = replace(text, "content: sale.png", "content: ../assets/sale.jpg");
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("missions/m.yaml", text), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_EQ(mission->map, dir_path / "maps/site.yaml");
  EXPECT_EQ(mission->robot_file, dir_path / "robots/ud.yaml");
  EXPECT_EQ(mission->robot.file, dir_path / "robots/ud.yaml");
  EXPECT_EQ(mission->targets[0].model, dir_path / "assets/models/bunny.ply");
  EXPECT_EQ(mission->targets[0].content, dir_path / "assets/sale.jpg");
  EXPECT_EQ(mission->targets[1].model, dir_path / "missions/bunny.ply");
}

TEST_F(MissionLoader, VideoContentNeedsOnlyToExist) {
  write("clip.mp4", "not decoded at load time");
  host::Diagnostics diag;
  const auto mission =
      host::load_mission(write("m.yaml", replace(kMission, "sale.png", "clip.mp4")), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_EQ(mission->targets[0].content, dir_path / "clip.mp4");
}

TEST_F(MissionLoader, InlineMachineIsKeptUninterpreted) {
  const std::string text =
      replace(kMission, "machine: default",
              "machine:\n  initial: go\n  states: {go: {behaviour: navigate}}");
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("m.yaml", text), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_FALSE(mission->machine.is_default);
  EXPECT_EQ(mission->machine.file, dir + "/m.yaml");
  EXPECT_EQ(mission->machine.path, "machine");
  EXPECT_EQ(mission->machine.node["initial"].as<std::string>(), "go");
  EXPECT_EQ(mission->machine.node["states"]["go"]["behaviour"].as<std::string>(), "navigate");
}

TEST_F(MissionLoader, MachineFromFileResolvesRelativeToMission) {
  write("machines/short.yaml", "initial: go\nstates: {go: {behaviour: navigate}}\n");
  host::Diagnostics diag;
  const auto mission = host::load_mission(
      write("m.yaml", replace(kMission, "machine: default", "machine: machines/short.yaml")), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_FALSE(mission->machine.is_default);
  EXPECT_EQ(mission->machine.file, dir + "/machines/short.yaml");
  EXPECT_EQ(mission->machine.path, "");
  EXPECT_EQ(mission->machine.node["initial"].as<std::string>(), "go");
}

TEST_F(MissionLoader, OrderNearestAndNoMachineKey) {
  std::string text = replace(kMission, "machine: default\n", "order: nearest\n");
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("m.yaml", text), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_EQ(mission->order, "nearest");
  EXPECT_TRUE(mission->machine.is_default);
}

TEST_F(MissionLoader, FromStringAnchorsPathsOnTheGivenName) {
  host::Diagnostics diag;
  const auto mission = host::load_mission_from_string(kMission, dir_path / "virtual.yaml", diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_EQ(mission->targets[0].model, dir_path / "bunny.ply");
  EXPECT_EQ(mission->file, dir_path / "virtual.yaml");
}

TEST_F(MissionLoader, OrThrowCarriesEveryDiagnostic) {
  std::string text = replace(kMission, "yaw_deg: 180", "yaw_deg: north");
  text = replace(text, "dwell_s: 15", "dwell_s: 0");
  const std::string file = write("m.yaml", text);
  try {
    host::load_mission_or_throw(file);
    FAIL() << "no InputError";
  } catch (const host::InputError& e) {
    EXPECT_EQ(e.diagnostics().error_count(), 2u);
    EXPECT_THAT(e.what(), HasSubstr(file + ":8:45: targets[0].pose.yaw_deg:"));
    EXPECT_THAT(e.what(), HasSubstr(file + ":12:14: targets[0].dwell_s:"));
  }
  EXPECT_EQ(host::load_mission_or_throw(write("good.yaml", kMission)).targets.size(), 2u);
}

// ---------------------------------------------------------------- wrong types

TEST_F(MissionLoader, YawNotANumber) {
  EXPECT_THAT(mission_errors(replace(kMission, "yaw_deg: 180", "yaw_deg: north")),
              ElementsAre(dir + "/m.yaml:8:45: targets[0].pose.yaw_deg: expected a number, got "
                                "\"north\""));
}

TEST_F(MissionLoader, StartCoordinateNotANumber) {
  EXPECT_THAT(mission_errors(replace(kMission, "{x: 1.0,", "{x: one,")),
              ElementsAre(dir + "/m.yaml:4:12: start.x: expected a number, got \"one\""));
}

TEST_F(MissionLoader, StandoffIsAList) {
  EXPECT_THAT(mission_errors(replace(kMission, "standoff_m: 1.2", "standoff_m: [1.2]")),
              ElementsAre(dir + "/m.yaml:11:17: targets[0].standoff_m: expected a number, got a "
                                "list"));
}

TEST_F(MissionLoader, IdIsAList) {
  EXPECT_THAT(mission_errors(replace(kMission, "id: hare", "id: [hare]")),
              ElementsAre(dir + "/m.yaml:13:9: targets[1].id: expected a string, got a list"));
}

TEST_F(MissionLoader, ModelPathIsAMapping) {
  EXPECT_THAT(mission_errors(replace(kMission, "model: bunny.ply", "model: {file: bunny.ply}")),
              ElementsAre(dir + "/m.yaml:7:12: targets[0].model: expected a string, got a "
                                "mapping"));
}

TEST_F(MissionLoader, PoseIsAScalar) {
  EXPECT_THAT(
      mission_errors(replace(kMission, "{x: 6.0, y: 2.0, z: 0.9, yaw_deg: 180}", "6.0 2.0 0.9")),
      ElementsAre(dir + "/m.yaml:8:11: targets[0].pose: expected a mapping, got \"6.0 2.0 0.9\""));
}

TEST_F(MissionLoader, StartIsAList) {
  EXPECT_THAT(mission_errors(replace(kMission, "{x: 1.0, y: 1.5, yaw_deg: 90}", "[1.0, 1.5, 90]")),
              ElementsAre(dir + "/m.yaml:4:8: start: expected a mapping, got a list"));
}

TEST_F(MissionLoader, TargetsNotAList) {
  const std::string text =
      "mission: a\nmap: map.yaml\nrobot: robot.yaml\n"
      "start: {x: 0, y: 0, yaw_deg: 0}\ntargets: rabbit\n";
  EXPECT_THAT(mission_errors(text),
              ElementsAre(dir + "/m.yaml:5:10: targets: expected a list, got \"rabbit\""));
}

TEST_F(MissionLoader, TargetsEmpty) {
  const std::string text =
      "mission: a\nmap: map.yaml\nrobot: robot.yaml\n"
      "start: {x: 0, y: 0, yaw_deg: 0}\ntargets: []\n";
  EXPECT_THAT(mission_errors(text),
              ElementsAre(dir + "/m.yaml:5:10: targets: expected at least one target"));
}

TEST_F(MissionLoader, TargetIsAScalar) {
  EXPECT_THAT(mission_errors(replace(kMission, "  - id: hare\n", "  - hare\n  - id: hare\n")),
              ElementsAre(dir + "/m.yaml:13:5: targets[1]: expected a mapping, got \"hare\""));
}

TEST_F(MissionLoader, ModelPointsIsAScalar) {
  EXPECT_THAT(mission_errors(replace(
                  kMission, "[[0.1, 0.0, 0.1], [0.1, 0.1, 0.1], [0.1, 0.1, 0.0], [0.1, 0.0, 0.0]]",
                  "corners")),
              ElementsAre(dir + "/m.yaml:16:19: targets[1].model_points: expected a list, got "
                                "\"corners\""));
}

TEST_F(MissionLoader, OrderNotOneOfTheWords) {
  EXPECT_THAT(mission_errors(replace(kMission, "machine: default", "order: nearset")),
              ElementsAre(dir + "/m.yaml:18:8: order: expected one of mission, nearest, got "
                                "\"nearset\"; did you mean \"nearest\"?"));
}

TEST_F(MissionLoader, MachineIsAList) {
  EXPECT_THAT(mission_errors(replace(kMission, "machine: default", "machine: [navigate, aim]")),
              ElementsAre(dir + "/m.yaml:18:10: machine: expected \"default\", a file path or a "
                                "state machine mapping, got a list"));
}

TEST_F(MissionLoader, MissionRootIsAList) {
  EXPECT_THAT(mission_errors("- mission: a\n- map: map.yaml\n"),
              ElementsAre(dir + "/m.yaml:1:1: expected a mapping, got a list"));
}

// ---------------------------------------------------------------- missing fields

TEST_F(MissionLoader, MissingMissionNameAtTheFileStart) {
  EXPECT_THAT(mission_errors(replace(kMission, "mission: atrium-spring-sale\n", "")),
              ElementsAre(dir + "/m.yaml:1:1: mission: missing required field"));
}

TEST_F(MissionLoader, MissingPoseAtItsTarget) {
  EXPECT_THAT(
      mission_errors(replace(kMission, "    pose: {x: 6.0, y: 2.0, z: 0.9, yaw_deg: 180}\n", "")),
      ElementsAre(dir + "/m.yaml:6:5: targets[0].pose: missing required field"));
}

TEST_F(MissionLoader, MissingYawAtItsPose) {
  EXPECT_THAT(mission_errors(replace(kMission, ", yaw_deg: 180}", "}")),
              ElementsAre(dir + "/m.yaml:8:11: targets[0].pose.yaw_deg: missing required field"));
}

TEST_F(MissionLoader, MissingModelPointsAndContent) {
  std::string text = replace(kMission, "    content: sale.png\n    standoff_m", "    standoff_m");
  text = replace(text,
                 "    model_points: [[0.1225, 0.0, 0.08], [0.1215, 0.06, 0.08], [0.089, 0.06, "
                 "-0.02], [0.1153, 0.0, -0.02]]\n",
                 "");
  EXPECT_THAT(mission_errors(text),
              ElementsAre(dir + "/m.yaml:6:5: targets[0].model_points: missing required field",
                          dir + "/m.yaml:6:5: targets[0].content: missing required field"));
}

// ---------------------------------------------------------------- unknown keys

TEST_F(MissionLoader, UnknownMissionKeySuggests) {
  EXPECT_THAT(mission_errors(replace(kMission, "machine: default", "machin: default")),
              ElementsAre(dir + "/m.yaml:18:1: machin: unknown key \"machin\"; did you mean "
                                "\"machine\"?"));
}

TEST_F(MissionLoader, UnknownTargetKeySuggests) {
  EXPECT_THAT(mission_errors(replace(kMission, "standoff_m: 1.2", "standof_m: 1.2")),
              ElementsAre(dir + "/m.yaml:11:5: targets[0].standof_m: unknown key \"standof_m\"; "
                                "did you mean \"standoff_m\"?"));
}

TEST_F(MissionLoader, UnknownPoseKeySuggestsAndYawIsMissing) {
  EXPECT_THAT(
      mission_errors(replace(kMission, "yaw_deg: -90", "yaw_dg: -90")),
      ElementsAre(dir +
                      "/m.yaml:15:36: targets[1].pose.yaw_dg: unknown key \"yaw_dg\"; did you mean "
                      "\"yaw_deg\"?",
                  dir + "/m.yaml:15:11: targets[1].pose.yaw_deg: missing required field"));
}

TEST_F(MissionLoader, UnknownStartKeyWithoutCloseMatch) {
  EXPECT_THAT(mission_errors(replace(kMission, "yaw_deg: 90}", "yaw_deg: 90, heading: 1}")),
              ElementsAre(dir + "/m.yaml:4:38: start.heading: unknown key \"heading\""));
}

// ---------------------------------------------------------------- files

TEST_F(MissionLoader, MissingModelFileNamesBothPaths) {
  EXPECT_THAT(mission_errors(replace(kMission, "model: bunny.ply", "model: models/rabbit.ply")),
              ElementsAre(dir +
                          "/m.yaml:7:12: targets[0].model: file \"models/rabbit.ply\" not "
                          "found (looked at " +
                          dir + "/models/rabbit.ply)"));
}

TEST_F(MissionLoader, MissingMapFile) {
  EXPECT_THAT(mission_errors(replace(kMission, "map: map.yaml", "map: ../atrium.yaml")),
              ElementsAre(dir + "/m.yaml:2:6: map: file \"../atrium.yaml\" not found (looked at " +
                          dir_path.parent_path().string() + "/atrium.yaml)"));
}

TEST_F(MissionLoader, MissingContentFile) {
  EXPECT_THAT(mission_errors(replace(kMission, "content: sale.png", "content: spring.png")),
              ElementsAre(dir +
                          "/m.yaml:10:14: targets[0].content: file \"spring.png\" not "
                          "found (looked at " +
                          dir + "/spring.png)"));
}

TEST_F(MissionLoader, MissingRobotFile) {
  EXPECT_THAT(mission_errors(replace(kMission, "robot: robot.yaml", "robot: ud.yaml")),
              ElementsAre(dir + "/m.yaml:3:8: robot: file \"ud.yaml\" not found (looked at " + dir +
                          "/ud.yaml)"));
}

TEST_F(MissionLoader, ModelOfUnknownFormat) {
  write("bunny.obj", "v 0 0 0\n");
  EXPECT_THAT(mission_errors(replace(kMission, "model: bunny.ply", "model: bunny.obj")),
              ElementsAre(dir + "/m.yaml:7:12: targets[0].model: expected a model file (.ply or "
                                ".off), got \"bunny.obj\""));
}

TEST_F(MissionLoader, ContentThatIsNoImage) {
  write("broken.png", "this is text, not a PNG");
  EXPECT_THAT(mission_errors(replace(kMission, "content: sale.png", "content: broken.png")),
              ElementsAre(dir +
                          "/m.yaml:10:14: targets[0].content: file \"broken.png\" is not "
                          "an image OpenCV can read (" +
                          dir + "/broken.png)"));
}

TEST_F(MissionLoader, MachineFileMissing) {
  EXPECT_THAT(mission_errors(replace(kMission, "machine: default", "machine: tour.yaml")),
              ElementsAre(dir +
                          "/m.yaml:18:10: machine: file \"tour.yaml\" not found (looked "
                          "at " +
                          dir + "/tour.yaml)"));
}

TEST_F(MissionLoader, MachineFileNotAMapping) {
  write("tour.yaml", "- navigate\n- aim\n");
  EXPECT_THAT(mission_errors(replace(kMission, "machine: default", "machine: tour.yaml")),
              ElementsAre(dir + "/tour.yaml:1:1: expected a state machine mapping"));
}

TEST_F(MissionLoader, MissingMissionFile) {
  host::Diagnostics diag;
  EXPECT_FALSE(host::load_mission(dir_path / "nowhere.yaml", diag));
  EXPECT_THAT(formatted(diag), ElementsAre(dir + "/nowhere.yaml: cannot open file"));
}

TEST_F(MissionLoader, SyntaxError) {
  EXPECT_THAT(mission_errors("mission: a\ntargets: [rabbit, hare\nmap: x.yaml\n"),
              ElementsAre(dir + "/m.yaml:3:4: YAML syntax error: end of sequence flow not found"));
}

TEST_F(MissionLoader, EmptyFile) {
  EXPECT_THAT(mission_errors(""),
              ElementsAre(dir + "/m.yaml:1:1: empty mission file: expected a mapping with "
                                "mission, map, robot, start and targets"));
}

// ---------------------------------------------------------------- semantic checks

TEST_F(MissionLoader, ThreeModelPoints) {
  EXPECT_THAT(
      mission_errors(replace(kMission, ", [0.1, 0.0, 0.0]]", "]")),
      ElementsAre(dir + "/m.yaml:16:19: targets[1].model_points: expected 4 points (top-left, "
                        "top-right, bottom-right, bottom-left), got 3"));
}

TEST_F(MissionLoader, ModelPointOfTwoNumbers) {
  EXPECT_THAT(mission_errors(replace(kMission, "[0.1215, 0.06, 0.08]", "[0.1215, 0.06]")),
              ElementsAre(dir + "/m.yaml:9:41: targets[0].model_points[1]: expected 3 numbers "
                                "[x, y, z], got 2"));
}

TEST_F(MissionLoader, ModelPointsOnALine) {
  EXPECT_THAT(
      mission_errors(replace(kMission, "[0.1, 0.1, 0.0], [0.1, 0.0, 0.0]]",
                             "[0.1, 0.2, 0.1], [0.1, 0.0, 0.0]]")),
      ElementsAre(dir + "/m.yaml:16:19: targets[1].model_points: points 0, 1 and 2 lie on one "
                        "line; the four corners must enclose an area"));
}

TEST_F(MissionLoader, DuplicateIdPointsAtTheSecond) {
  EXPECT_THAT(mission_errors(replace(kMission, "id: hare", "id: rabbit")),
              ElementsAre(dir + "/m.yaml:13:9: targets[1].id: duplicate target id \"rabbit\" "
                                "(first used at line 6)"));
}

TEST_F(MissionLoader, IdThatCannotNameADirectory) {
  EXPECT_THAT(mission_errors(replace(kMission, "id: hare", "id: ../hare")),
              ElementsAre(dir + "/m.yaml:13:9: targets[1].id: expected an id of letters, "
                                "digits, '_' and '-' (it names a directory), got \"../hare\""));
}

TEST_F(MissionLoader, NegativeStandoff) {
  EXPECT_THAT(mission_errors(replace(kMission, "standoff_m: 1.2", "standoff_m: -1")),
              ElementsAre(dir + "/m.yaml:11:17: targets[0].standoff_m: expected a number > 0, "
                                "got -1"));
}

TEST_F(MissionLoader, ZeroDwell) {
  EXPECT_THAT(mission_errors(replace(kMission, "dwell_s: 15", "dwell_s: 0")),
              ElementsAre(dir + "/m.yaml:12:14: targets[0].dwell_s: expected a number > 0, got 0"));
}

// Numbers no tour can use: a dwell of 10^9 s never ends, a stand-off of a kilometre never
// arrives, a tolerance of 10 m verifies anything.
TEST_F(MissionLoader, AbsurdDwellStandoffAndTolerance) {
  EXPECT_THAT(mission_errors(replace(kMission, "dwell_s: 15", "dwell_s: 1e9")),
              ElementsAre(dir + "/m.yaml:12:14: targets[0].dwell_s: expected a number > 0 and at "
                                "most 86400, got 1e9"));
  EXPECT_THAT(mission_errors(replace(kMission, "standoff_m: 1.2", "standoff_m: 1000")),
              ElementsAre(dir + "/m.yaml:11:17: targets[0].standoff_m: expected a number > 0 and "
                                "at most 20, got 1000"));
  EXPECT_THAT(
      mission_errors(replace(kMission, "dwell_s: 15", "dwell_s: 15\n    tolerance_mm: 10000")),
      ElementsAre(dir + "/m.yaml:13:19: targets[0].tolerance_mm: expected a number > 0 and at "
                        "most 1000, got 10000"));
}

TEST_F(MissionLoader, ToleranceNotPositiveOrNotANumber) {
  for (const char* bad : {"0", "-1.5"}) {
    EXPECT_THAT(
        mission_errors(
            replace(kMission, "dwell_s: 15", "dwell_s: 15\n    tolerance_mm: " + std::string(bad))),
        ElementsAre(dir + "/m.yaml:13:19: targets[0].tolerance_mm: expected a number > 0, got " +
                    bad));
  }
  EXPECT_THAT(mission_errors(replace(kMission, "    content: sale.png\nmachine",
                                     "    content: sale.png\n    tolerance_mm: tight\nmachine")),
              ElementsAre(dir + "/m.yaml:18:19: targets[1].tolerance_mm: expected a number, got "
                                "\"tight\""));
}

TEST_F(MissionLoader, UnknownToleranceSpellingSuggests) {
  EXPECT_THAT(mission_errors(replace(kMission, "dwell_s: 15", "dwell_s: 15\n    tolerance: 2")),
              ElementsAre(dir + "/m.yaml:13:5: targets[0].tolerance: unknown key \"tolerance\"; "
                                "did you mean \"tolerance_mm\"?"));
}

TEST_F(MissionLoader, YawOutOfRange) {
  EXPECT_THAT(mission_errors(replace(kMission, "yaw_deg: -90", "yaw_deg: -450")),
              ElementsAre(dir + "/m.yaml:15:45: targets[1].pose.yaw_deg: expected an angle in "
                                "degrees within [-360, 360], got -450"));
}

TEST_F(MissionLoader, RepeatedKeyIsAnError) {
  EXPECT_THAT(mission_errors(replace(kMission, "dwell_s: 15", "dwell_s: 15\n    dwell_s: 20")),
              ElementsAre(dir + "/m.yaml:13:5: targets[0].dwell_s: duplicate key \"dwell_s\" "
                                "(first at line 12)"));
}

TEST_F(MissionLoader, SeveralErrorsAllReportedInFileOrder) {
  std::string text = replace(kMission, "robot: robot.yaml", "robot: robot.yaml\ncolour: red");
  text = replace(text, "yaw_deg: 180", "yaw_deg: north");                         // line 9
  text = replace(text, "content: sale.png", "content: missing.png");              // line 11
  text = replace(text, "id: hare", "id: rabbit");                                 // line 14
  text = replace(text, "[0.1, 0.1, 0.0], [0.1, 0.0, 0.0]]", "[0.1, 0.1, 0.0]]");  // line 17
  EXPECT_THAT(
      mission_errors(text),
      ElementsAre(
          dir + "/m.yaml:4:1: colour: unknown key \"colour\"",
          dir + "/m.yaml:9:45: targets[0].pose.yaw_deg: expected a number, got \"north\"",
          dir + "/m.yaml:11:14: targets[0].content: file \"missing.png\" not found (looked at " +
              dir + "/missing.png)",
          dir + "/m.yaml:14:9: targets[1].id: duplicate target id \"rabbit\" (first used at "
                "line 7)",
          dir + "/m.yaml:17:19: targets[1].model_points: expected 4 points (top-left, "
                "top-right, bottom-right, bottom-left), got 3"));
}

}  // namespace
}  // namespace projtour::test
