// The checks before a run (run_checks.hpp): every model opened, every content decoded, the Model
// Points against the surface and the front, the stand-off against the robot and the head's
// reach; each diagnostic exactly (file, line, column, field path, message).
#include <algorithm>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "projtour/host/mission_loader.hpp"
#include "projtour/tour/run_checks.hpp"
#include "projtour/tour/runner.hpp"
#include "projtour_test/loader_fixture.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;
using ::testing::IsEmpty;

// A cube of 0.2 m about the origin, its front face at x = +0.1; the Model Points on that face,
// top-left first as seen from +x.
const char* const kChecksMission = R"(mission: checks
map: map.yaml
robot: robot.yaml
start: {x: 1.0, y: 1.0, yaw_deg: 0}
targets:
  - id: cube
    model: cube.off
    pose: {x: 3.0, y: 1.0, z: 1.0, yaw_deg: 180}
    model_points: [[0.1, -0.05, 0.05], [0.1, 0.05, 0.05], [0.1, 0.05, -0.05], [0.1, -0.05, -0.05]]
    content: sale.png
    standoff_m: 1.2
)";

// Vertex i has x, y, z of +-0.1 by its bits 0, 1, 2; each face a quad (fanned by the reader).
std::string cube_off(double scale = 1.0, const std::string& first_vertex = "") {
  std::string text = "OFF\n8 6 0\n";
  for (int i = 0; i < 8; ++i) {
    if (i == 0 && !first_vertex.empty()) {
      text += first_vertex + "\n";
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      text += std::to_string(((i >> axis) & 1 ? 0.1 : -0.1) * scale) + (axis < 2 ? " " : "\n");
    }
  }
  return text + "4 0 2 6 4\n4 1 5 7 3\n4 0 1 3 2\n4 4 6 7 5\n4 0 4 5 1\n4 2 3 7 6\n";
}

class RunChecks : public LoaderTest {
 protected:
  void SetUp() override {
    LoaderTest::SetUp();
    write("cube.off", cube_off());
  }

  // Check problems of the mission `text` (which must load).
  std::vector<std::string> problems(const std::string& text) const {
    host::Diagnostics diag;
    const auto mission = host::load_mission(write("m.yaml", text), diag);
    EXPECT_TRUE(mission) << diag.format();
    if (!mission) return {};
    check_run_assets(*mission, diag);
    return formatted(diag);
  }
  std::vector<std::string> model_problems(const std::string& model_text,
                                          const std::string& name = "cube.off") const {
    write(name, model_text);
    return problems(replace(kChecksMission, "cube.off", name));
  }
  std::string at(const std::string& where) const { return dir + "/m.yaml:" + where; }
};

TEST_F(RunChecks, CubeMissionPasses) {
  EXPECT_THAT(problems(kChecksMission), IsEmpty());
}

TEST_F(RunChecks, ModelWithNanVertex) {
  EXPECT_THAT(model_problems(cube_off(1.0, "nan -0.1 -0.1")),
              ElementsAre(at("7:12: targets[0].model: ") + dir +
                          "/cube.off: vertex 0 is not finite (nan, -0.1, -0.1); expected finite "
                          "coordinates in metres"));
}

TEST_F(RunChecks, TruncatedPly) {
  EXPECT_THAT(model_problems("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                             "float y\nproperty float z\nelement face 1\nproperty list uchar int "
                             "vertex_indices\nend_header\n0 0 0\n0.1 0",
                             "cut.ply"),
              ElementsAre(at("7:12: targets[0].model: ") + dir +
                          "/cut.ply: cannot read as PLY; expected a triangle mesh (PLY or OFF)"));
}

TEST_F(RunChecks, ModelWithoutTriangles) {
  EXPECT_THAT(model_problems("OFF\n3 0 0\n0 0 0\n0.1 0 0\n0 0.1 0\n"),
              ElementsAre(at("7:12: targets[0].model: ") + dir +
                          "/cube.off: holds no triangles; expected a triangle mesh (PLY or OFF)"));
}

TEST_F(RunChecks, FaceIndexOutOfRange) {
  EXPECT_THAT(model_problems(replace(cube_off(), "4 2 3 7 6", "4 2 3 7 8")),
              ElementsAre(at("7:12: targets[0].model: ") + dir +
                          "/cube.off: face index out of range; expected a triangle mesh (PLY or "
                          "OFF)"));
}

TEST_F(RunChecks, ModelInMillimetres) {
  EXPECT_THAT(model_problems(cube_off(1000.0)),
              ElementsAre(at("7:12: targets[0].model: ") + dir +
                          "/cube.off: vertex 0 lies 173 m from the model's origin; expected a "
                          "model in metres within 20 m of its origin"));
}

TEST_F(RunChecks, CorruptPng) {
  // The signature is a PNG's, the body is not.
  write("broken.png", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(64, 'x'));
  EXPECT_THAT(problems(replace(kChecksMission, "sale.png", "broken.png")),
              ElementsAre(at("10:14: targets[0].content: cannot decode ") + dir +
                          "/broken.png; expected an image OpenCV can decode"));
}

TEST_F(RunChecks, UndecodableVideo) {
  write("clip.mp4", std::string(4096, 'v'));
  EXPECT_THAT(problems(replace(kChecksMission, "sale.png", "clip.mp4")),
              ElementsAre(at("10:14: targets[0].content: cannot decode ") + dir +
                          "/clip.mp4; expected a video whose first frame OpenCV can decode"));
}

// Every item of a content list is decoded, each reported at its place in the list.
TEST_F(RunChecks, UndecodableItemOfAContentList) {
  write("clip.mp4", std::string(4096, 'v'));
  EXPECT_THAT(
      problems(replace(kChecksMission, "content: sale.png", "content: [sale.png, clip.mp4]")),
      ElementsAre(at("10:25: targets[0].content[1]: cannot decode ") + dir +
                  "/clip.mp4; expected a video whose first frame OpenCV can decode"));
}

TEST_F(RunChecks, ModelPointFiveCentimetresOffTheSurface) {
  EXPECT_THAT(problems(replace(kChecksMission, "[0.1, 0.05, -0.05]", "[0.15, 0.05, -0.05]")),
              ElementsAre(at("9:59: targets[0].model_points[2]: point (0.15, 0.05, -0.05) lies "
                             "0.05 m from the model's surface; expected within 0.01 m of it")));
}

TEST_F(RunChecks, SelfCrossingModelPoints) {
  EXPECT_THAT(
      problems(replace(kChecksMission, "[0.1, 0.05, -0.05], [0.1, -0.05, -0.05]]",
                       "[0.1, -0.05, -0.05], [0.1, 0.05, -0.05]]")),
      ElementsAre(at("9:19: targets[0].model_points: the four points cross over themselves (a "
                     "bow-tie); expected them in order around the area: top-left, top-right, "
                     "bottom-right, bottom-left")));
}

TEST_F(RunChecks, BackFacingModelPoints) {
  EXPECT_THAT(
      problems(replace(kChecksMission,
                       "[[0.1, -0.05, 0.05], [0.1, 0.05, 0.05], [0.1, 0.05, -0.05], [0.1, -0.05, "
                       "-0.05]]",
                       "[[0.1, 0.05, 0.05], [0.1, -0.05, 0.05], [0.1, -0.05, -0.05], [0.1, 0.05, "
                       "-0.05]]")),
      ElementsAre(at("9:19: targets[0].model_points: the four points face away from the model's "
                     "front (+x): seen from the front they run counter-clockwise, so the content "
                     "would show mirrored; expected top-left, top-right, bottom-right, bottom-left "
                     "as seen from +x")));
}

TEST_F(RunChecks, StandoffInsideTheRobot) {
  EXPECT_THAT(problems(replace(kChecksMission, "standoff_m: 1.2", "standoff_m: 0.05")),
              ElementsAre(at("11:17: targets[0].standoff_m: stand-off 0.05 m puts the robot's "
                             "base (radius 0.3 m) into the target or within 0.1 m of its front; "
                             "expected at least 0.5 m")));
}

TEST_F(RunChecks, AimPointOutOfTheHeadsReach) {
  EXPECT_THAT(problems(replace(kChecksMission, "z: 1.0, yaw_deg: 180", "z: 5.0, yaw_deg: 180")),
              ElementsAre(at("11:17: targets[0].standoff_m: from the stand-off pose the aim "
                             "point (the Model Points' centre, (1.1, 0, 5) m in the base frame) "
                             "is out of the head's reach: needs pan 180.0 deg outside [-170.0, "
                             "170.0] deg; or needs tilt -74.2 deg (positive looks down) outside "
                             "[-30.0, 60.0] deg; expected a stand-off and pose the pan-tilt "
                             "limits can aim from")));
}

// The whole command on the campus map with the repository's robot, as a user runs it.
class ValidateCommand : public LoaderTest {
 protected:
  void SetUp() override {
    LoaderTest::SetUp();
    std::ifstream in(std::string(PROJTOUR_SOURCE_DIR) + "/examples/robot/ud.yaml");
    std::stringstream text;
    text << in.rdbuf();
    robot_text = text.str();
    write("hokuyo.ini", "");
  }

  std::string mission_text(const std::string& model) const {
    return "mission: campus\nmap: " + std::string(PROJTOUR_SOURCE_DIR) +
           "/maps/malaga_campus.yaml\nrobot: robot.yaml\nstart: {x: -5.5, y: -15.0, yaw_deg: "
           "-90}\ntargets:\n  - id: rabbit\n    model: " +
           model +
           "\n    pose: {x: -8.04, y: -23.16, z: 0.9, yaw_deg: 0}\n    model_points: [[0.1165, "
           "-0.0044, 0.0911], [0.1230, 0.0374, 0.0884], [0.1250, 0.0410, 0.0476], [0.1259, "
           "-0.0009, 0.0539]]\n    content: sale.png\n";
  }

  // Exit code of `projtour validate --dry-run` (or `run --dry-run`), its stderr in `err`.
  int command(const std::string& robot, const std::string& mission, bool run = false) {
    write("robot.yaml", robot);
    RunOptions options;
    options.mission = write("m.yaml", mission);
    options.dry_run = true;
    options.plugin_paths = {PROJTOUR_PLUGIN_BUILD_DIR};
    options.out = dir_path / "run";
    std::ostringstream out, errors;
    const int code =
        run ? run_command(options, out, errors) : validate_command(options, out, errors);
    err = errors.str();
    return code;
  }

  const std::string bunny = std::string(PROJTOUR_SOURCE_DIR) + "/examples/models/bunny.ply";
  std::string robot_text;
  std::string err;
};

TEST_F(ValidateCommand, CampusMissionIsOk) {
  EXPECT_EQ(command(robot_text, mission_text(bunny)), 0) << err;
}

TEST_F(ValidateCommand, AbsurdParticleCountExitsTwo) {
  EXPECT_EQ(command(replace(robot_text, "localization: {kind: mrpt_localization}",
                            "localization: {kind: mrpt_localization, params: {particles: "
                            "2000000000}}"),
                    mission_text(bunny)),
            2);
  // First of the diagnostics (the services it would have run are missing after it), on the line
  // of ud.yaml that names the service.
  const std::string before = robot_text.substr(0, robot_text.find("localization: {kind:"));
  const auto line = std::count(before.begin(), before.end(), '\n') + 1;
  EXPECT_THAT(err, ::testing::StartsWith(dir + "/robot.yaml:" + std::to_string(line) +
                                         ":63: "
                                         "services.localization.params.particles: expected "
                                         "from 10 to 1000000, got 2000000000\n"));
}

// The simulator crashed on a non-finite vertex once the run had started; now neither validate
// nor a run gets that far, and no run directory is made.
TEST_F(ValidateCommand, ModelWithNanVertexStopsValidateAndRunBeforeAnythingMoves) {
  write("nan.off", cube_off(1.0, "nan -0.1 -0.1"));
  const std::string line = dir + "/m.yaml:7:12: targets[0].model: " + dir +
                           "/nan.off: vertex 0 is not finite (nan, -0.1, -0.1); expected finite "
                           "coordinates in metres\n";
  EXPECT_EQ(command(robot_text, mission_text("nan.off")), 2);
  EXPECT_THAT(err, ::testing::HasSubstr(line));
  EXPECT_EQ(command(robot_text, mission_text("nan.off"), true), 2);
  EXPECT_THAT(err, ::testing::HasSubstr(line));
  EXPECT_THAT(err, ::testing::HasSubstr("nothing moved"));
  EXPECT_FALSE(std::filesystem::exists(dir_path / "run"));
}

}  // namespace
}  // namespace projtour::test
