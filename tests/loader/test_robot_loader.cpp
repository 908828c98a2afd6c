// Robot files: the shipped example, values and defaults, and exact diagnostics for bad input.
#include <cmath>

#include "loader_fixture.hpp"
#include "projtour/geometry.hpp"
#include "projtour/mission_loader.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;

class RobotLoader : public LoaderTest {};

// ---------------------------------------------------------------- good input

TEST_F(RobotLoader, ShippedUbiquitousDisplayLoads) {
  Diagnostics diag;
  const auto robot = load_robot(PROJTOUR_SOURCE_DIR "/examples/robot/ud.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  EXPECT_TRUE(diag.items().empty()) << diag.format();
  EXPECT_EQ(robot->name, "ubiquitous-display");
  EXPECT_DOUBLE_EQ(robot->base.radius_m, 0.3);
  EXPECT_EQ(robot->laser.rays, 541);
  EXPECT_DOUBLE_EQ(robot->laser.fov_deg, 270.0);
  EXPECT_DOUBLE_EQ(robot->laser.max_range_m, 20.0);
  EXPECT_NEAR(robot->pan_tilt.T_base_pan0.translation().z(), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.pan_min_deg, -170.0);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.pan_max_deg, 170.0);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.tilt_min_deg, -30.0);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.tilt_max_deg, 60.0);
  EXPECT_EQ(robot->camera.mount.link, Link::pan);
  EXPECT_EQ(robot->projector.mount.link, Link::tilt);
  EXPECT_EQ(robot->camera.intrinsics.width, 640);
  EXPECT_DOUBLE_EQ(robot->camera.intrinsics.fx, 525.0);
  EXPECT_DOUBLE_EQ(robot->camera.intrinsics.cx, 319.5);
  EXPECT_TRUE(robot->camera.depth_to_color_m.isApprox(Eigen::Vector3d(0.05, 0, 0)));
  EXPECT_EQ(robot->projector.intrinsics.width, 1280);
  EXPECT_EQ(robot->projector.intrinsics.height, 800);
  EXPECT_NEAR(robot->projector.intrinsics.throw_ratio(), 1.5, 0.05);
  EXPECT_TRUE(robot->projector.intrinsics.has_distortion());
  ASSERT_EQ(robot->drivers.size(), 4u);
  EXPECT_EQ(robot->drivers.at("depth_camera").kind, "openni2");
  EXPECT_EQ(robot->drivers.at("pan_tilt").kind, "ptu_dperception");
  EXPECT_EQ(robot->drivers.at("laser").kind, "mrpt_sensor");
  EXPECT_EQ(robot->drivers.at("projector").kind, "display");
  EXPECT_EQ(robot->drivers.at("pan_tilt").params_path, "drivers.pan_tilt.params");
  EXPECT_EQ(robot->drivers.at("pan_tilt").params["port"].as<std::string>(), "/dev/ttyUSB0");
  EXPECT_EQ(robot->services.at("localization").kind, "mrpt_localization");
}

TEST_F(RobotLoader, PitchTurnsTheCameraNoseDown) {
  Diagnostics diag;
  const auto robot = load_robot(dir_path / "robot.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  // Body x (the optical axis) after pitch 20 about y: forward and 20 degrees below horizontal.
  const Eigen::Vector3d axis = robot->camera.mount.T_link_body.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(axis.z(), -std::sin(deg_to_rad(20.0)), 1e-12);
  EXPECT_NEAR(axis.x(), std::cos(deg_to_rad(20.0)), 1e-12);
  EXPECT_TRUE(
      robot->camera.mount.T_link_body.translation().isApprox(Eigen::Vector3d(0.08, 0, 0.25)));
}

TEST_F(RobotLoader, OptionalFieldsTakeDefaults) {
  Diagnostics diag;
  const auto robot = load_robot(dir_path / "robot.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  const RobotSpec defaults;
  EXPECT_DOUBLE_EQ(robot->base.max_speed_mps, defaults.base.max_speed_mps);
  EXPECT_EQ(robot->laser.rays, defaults.laser.rays);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.max_rate_dps, defaults.pan_tilt.max_rate_dps);
  EXPECT_DOUBLE_EQ(robot->camera.min_range_m, defaults.camera.min_range_m);
  EXPECT_TRUE(robot->camera.depth_to_color_m.isZero());
  ASSERT_EQ(robot->drivers.size(), 1u);
  EXPECT_EQ(robot->drivers.at("pan_tilt").mark.line, 31);
  EXPECT_EQ(robot->drivers.at("pan_tilt").mark.column, 45);
  // Without a services section localization is MRPT's with its default parameters.
  ASSERT_EQ(robot->services.size(), 1u);
  EXPECT_EQ(robot->services.at("localization").kind, "mrpt_localization");
  EXPECT_FALSE(robot->services.at("localization").params.IsDefined());
  EXPECT_EQ(robot->services.at("localization").params_path, "services.localization.params");
}

// A driver written without params used to get a default-constructed YAML::Node, which is Null
// (as if "params: ~" had been written), not Undefined as PluginInstanceSpec documents.
TEST_F(RobotLoader, Regression_AbsentDriverParamsAreUndefinedNotNull) {
  Diagnostics diag;
  const auto robot =
      load_robot(write("r.yaml", replace(kRobot, ", params: {port: /dev/ttyUSB0}", "")), diag);
  ASSERT_TRUE(robot) << diag.format();
  const PluginInstanceSpec& pan_tilt = robot->drivers.at("pan_tilt");
  EXPECT_EQ(pan_tilt.kind, "ptu_dperception");
  EXPECT_FALSE(pan_tilt.params.IsDefined());
  EXPECT_EQ(pan_tilt.params_path, "drivers.pan_tilt.params");
  EXPECT_EQ(pan_tilt.mark.line, 31);
  EXPECT_EQ(pan_tilt.mark.column, 13);
}

// ---------------------------------------------------------------- bad input

TEST_F(RobotLoader, ErrorsCarryTheRobotFileNameThroughTheMission) {
  write("robots/ud.yaml", replace(kRobot, "fx: 1920", "fx: wide"));
  EXPECT_THAT(mission_errors(replace(kMission, "robot: robot.yaml", "robot: robots/ud.yaml")),
              ElementsAre(dir + "/robots/ud.yaml:25:7: projector.fx: expected a number, got "
                                "\"wide\""));
}

TEST_F(RobotLoader, UnknownSectionSuggestsAndTheRealOneIsMissing) {
  EXPECT_THAT(robot_errors(replace(kRobot, "projector:", "projecter:")),
              ElementsAre(dir + "/r.yaml:20:1: projecter: unknown key \"projecter\"; did you "
                                "mean \"projector\"?",
                          dir + "/r.yaml:1:1: projector: missing required field"));
}

TEST_F(RobotLoader, UnknownPoseKeySuggests) {
  EXPECT_THAT(robot_errors(replace(kRobot, "pitch_deg: 20", "pitch_dg: 20")),
              ElementsAre(dir + "/r.yaml:13:46: camera.pose.pitch_dg: unknown key \"pitch_dg\"; "
                                "did you mean \"pitch_deg\"?"));
}

TEST_F(RobotLoader, UnknownDriverRoleSuggests) {
  EXPECT_THAT(robot_errors(replace(kRobot, "  pan_tilt: {kind", "  pantilt: {kind")),
              ElementsAre(dir + "/r.yaml:31:3: drivers.pantilt: unknown key \"pantilt\"; did "
                                "you mean \"pan_tilt\"?"));
}

TEST_F(RobotLoader, TiltLimitsReversed) {
  EXPECT_THAT(robot_errors(replace(kRobot, "[-30, 60]", "[60, -30]")),
              ElementsAre(dir + "/r.yaml:9:20: pan_tilt.tilt_limits_deg: expected [min, max] "
                                "with -360 <= min < max <= 360, got [60, -30]"));
}

TEST_F(RobotLoader, StowOutsideLimits) {
  EXPECT_THAT(robot_errors(replace(kRobot, "tilt_deg: 0", "tilt_deg: 75")),
              ElementsAre(dir + "/r.yaml:10:32: pan_tilt.stow.tilt_deg: stow angle 75 lies "
                                "outside tilt_limits_deg [-30, 60]"));
}

TEST_F(RobotLoader, MountNotPanOrTilt) {
  EXPECT_THAT(robot_errors(replace(kRobot, "mount: tilt", "mount: head")),
              ElementsAre(dir + "/r.yaml:21:10: projector.mount: expected one of pan, tilt, got "
                                "\"head\""));
}

TEST_F(RobotLoader, DistortionOfFourNumbers) {
  EXPECT_THAT(robot_errors(replace(kRobot, "[0.01, -0.005, 0, 0, 0]", "[0.01, -0.005, 0, 0]")),
              ElementsAre(dir + "/r.yaml:29:15: projector.distortion: expected 5 numbers [k1, "
                                "k2, p1, p2, k3], got 4"));
}

TEST_F(RobotLoader, WidthNotAnInteger) {
  EXPECT_THAT(robot_errors(replace(kRobot, "width: 640", "width: 640.5")),
              ElementsAre(dir + "/r.yaml:14:10: camera.width: expected an integer, got "
                                "\"640.5\""));
}

TEST_F(RobotLoader, PrincipalPointOutsideTheImage) {
  EXPECT_THAT(robot_errors(replace(kRobot, "cx: 319.5", "cx: 700")),
              ElementsAre(dir + "/r.yaml:18:7: camera.cx: principal point x 700 lies outside "
                                "the image [0, 640]"));
}

TEST_F(RobotLoader, DriverWithoutKind) {
  EXPECT_THAT(robot_errors(replace(kRobot, "{kind: ptu_dperception, params", "{params")),
              ElementsAre(dir + "/r.yaml:31:13: drivers.pan_tilt.kind: missing required field"));
}

TEST_F(RobotLoader, DriverParamsNotAMapping) {
  EXPECT_THAT(robot_errors(replace(kRobot, "{port: /dev/ttyUSB0}", "/dev/ttyUSB0")),
              ElementsAre(dir + "/r.yaml:31:45: drivers.pan_tilt.params: expected a mapping, "
                                "got \"/dev/ttyUSB0\""));
}

TEST_F(RobotLoader, MissingRadiusAtItsSection) {
  EXPECT_THAT(robot_errors(replace(kRobot, "{radius_m: 0.3}", "{}")),
              ElementsAre(dir + "/r.yaml:2:7: base.radius_m: missing required field"));
}

TEST_F(RobotLoader, EmptyRobotFile) {
  EXPECT_THAT(robot_errors("# nothing yet\n"),
              ElementsAre(dir + "/r.yaml:1:1: empty robot file: expected a mapping with robot, "
                                "base, laser, pan_tilt, camera and projector"));
}

}  // namespace
}  // namespace projtour::test
