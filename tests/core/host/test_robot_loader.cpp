// Robot files: the shipped example, values and defaults, and exact diagnostics for bad input.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>

#include "projtour/contract/geometry.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour_test/loader_fixture.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;

class RobotLoader : public LoaderTest {};

// kRobot with a camera.colour block (starting at line 20, its fields from line 21) ...
std::string with_colour(const std::string& fields) {
  return replace(kRobot, "  cy: 239.5\n", "  cy: 239.5\n  colour:\n" + fields);
}
// ... or a structured_light section (line 30, its fields from line 31).
std::string with_structured_light(const std::string& fields) {
  return replace(kRobot, "drivers:", "structured_light:\n" + fields + "drivers:");
}

struct BadValue {
  std::string fields;    // what the section holds
  std::string expected;  // the one diagnostic, after "<dir>/r.yaml:"
};

// ---------------------------------------------------------------- good input

TEST_F(RobotLoader, ShippedUbiquitousDisplayLoads) {
  host::Diagnostics diag;
  const auto robot = host::load_robot(PROJTOUR_SOURCE_DIR "/examples/robot/ud.yaml", diag);
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
  const PinholeModel& colour = robot->camera.colour.intrinsics;
  EXPECT_EQ(colour.width, 640);
  EXPECT_EQ(colour.height, 480);
  EXPECT_DOUBLE_EQ(colour.fx, 525.0);
  EXPECT_DOUBLE_EQ(colour.cy, 239.5);
  EXPECT_DOUBLE_EQ(colour.distortion[0], 0.2624);
  EXPECT_DOUBLE_EQ(colour.distortion[4], 1.1633);
  EXPECT_DOUBLE_EQ(robot->camera.colour.rate_hz, 30.0);
  ASSERT_EQ(robot->drivers.size(), 5u);
  EXPECT_EQ(robot->drivers.at("depth_camera").kind, "openni2");
  EXPECT_EQ(robot->drivers.at("colour_camera").kind, "openni2_colour");
  EXPECT_EQ(robot->drivers.at("pan_tilt").kind, "ptu_dperception");
  EXPECT_EQ(robot->drivers.at("laser").kind, "mrpt_sensor");
  EXPECT_EQ(robot->drivers.at("projector").kind, "display");
  EXPECT_EQ(robot->drivers.at("pan_tilt").params_path, "drivers.pan_tilt.params");
  EXPECT_EQ(robot->drivers.at("pan_tilt").params["port"].as<std::string>(), "/dev/ttyUSB0");
  EXPECT_EQ(robot->services.at("localization").kind, "mrpt_localization");
}

// ud.yaml documents structured_light as a commented section of its defaults: uncommented, it
// must load and say what the defaults are.
TEST_F(RobotLoader, DocumentedStructuredLightIsTheDefaults) {
  std::ifstream in(PROJTOUR_SOURCE_DIR "/examples/robot/ud.yaml");
  std::string text, line;
  bool in_section = false, found = false;
  while (std::getline(in, line)) {
    if (line == "# structured_light:") in_section = found = true;
    if (in_section && line.rfind("# ", 0) == 0) {
      line.erase(0, 2);
    } else {
      in_section = false;
    }
    text += line + "\n";
  }
  ASSERT_TRUE(found) << "ud.yaml lacks its commented structured_light section";
  host::Diagnostics diag;
  const auto robot = host::load_robot(write("ud.yaml", text), diag);
  ASSERT_TRUE(robot) << diag.format();
  const StructuredLightSpec defaults;
  const StructuredLightSpec& light = robot->structured_light;
  EXPECT_EQ(light.block_px, defaults.block_px);
  EXPECT_NEAR(light.hold_s, defaults.hold_s, 1e-4);  // written to four places
  EXPECT_DOUBLE_EQ(light.exposure_ms, defaults.exposure_ms);
  EXPECT_EQ(light.min_correspondences, defaults.min_correspondences);
  EXPECT_DOUBLE_EQ(light.max_residual_px, defaults.max_residual_px);
}

TEST_F(RobotLoader, PitchTurnsTheCameraNoseDown) {
  host::Diagnostics diag;
  const auto robot = host::load_robot(dir_path / "robot.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  // Body x (the optical axis) after pitch 20 about y: forward and 20 degrees below horizontal.
  const Eigen::Vector3d axis = robot->camera.mount.T_link_body.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(axis.z(), -std::sin(deg_to_rad(20.0)), 1e-12);
  EXPECT_NEAR(axis.x(), std::cos(deg_to_rad(20.0)), 1e-12);
  EXPECT_TRUE(
      robot->camera.mount.T_link_body.translation().isApprox(Eigen::Vector3d(0.08, 0, 0.25)));
}

TEST_F(RobotLoader, OptionalFieldsTakeDefaults) {
  host::Diagnostics diag;
  const auto robot = host::load_robot(dir_path / "robot.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  const RobotSpec defaults;
  EXPECT_DOUBLE_EQ(robot->base.max_speed_mps, defaults.base.max_speed_mps);
  EXPECT_EQ(robot->laser.rays, defaults.laser.rays);
  EXPECT_DOUBLE_EQ(robot->pan_tilt.max_rate_dps, defaults.pan_tilt.max_rate_dps);
  EXPECT_DOUBLE_EQ(robot->camera.min_range_m, defaults.camera.min_range_m);
  EXPECT_TRUE(robot->camera.depth_to_color_m.isZero());
  // Without camera.colour: the Kinect v1's colour camera.
  const ColourCameraSpec& colour = robot->camera.colour;
  EXPECT_EQ(colour.intrinsics.width, defaults.camera.colour.intrinsics.width);
  EXPECT_EQ(colour.intrinsics.height, defaults.camera.colour.intrinsics.height);
  EXPECT_DOUBLE_EQ(colour.intrinsics.fx, defaults.camera.colour.intrinsics.fx);
  EXPECT_DOUBLE_EQ(colour.intrinsics.cx, defaults.camera.colour.intrinsics.cx);
  EXPECT_EQ(colour.intrinsics.distortion, defaults.camera.colour.intrinsics.distortion);
  EXPECT_DOUBLE_EQ(colour.rate_hz, defaults.camera.colour.rate_hz);
  const StructuredLightSpec& light = robot->structured_light;
  EXPECT_EQ(light.block_px, defaults.structured_light.block_px);
  EXPECT_DOUBLE_EQ(light.hold_s, defaults.structured_light.hold_s);
  EXPECT_DOUBLE_EQ(light.exposure_ms, defaults.structured_light.exposure_ms);
  EXPECT_EQ(light.min_correspondences, defaults.structured_light.min_correspondences);
  EXPECT_DOUBLE_EQ(light.max_residual_px, defaults.structured_light.max_residual_px);
  ASSERT_EQ(robot->drivers.size(), 1u);
  EXPECT_EQ(robot->drivers.at("pan_tilt").mark.line, 31);
  EXPECT_EQ(robot->drivers.at("pan_tilt").mark.column, 45);
  // Without a services section localization is MRPT's with its default parameters.
  ASSERT_EQ(robot->services.size(), 1u);
  EXPECT_EQ(robot->services.at("localization").kind, "mrpt_localization");
  EXPECT_FALSE(robot->services.at("localization").params.IsDefined());
  EXPECT_EQ(robot->services.at("localization").params_path, "services.localization.params");
}

TEST_F(RobotLoader, ColourCameraValuesAreRead) {
  host::Diagnostics diag;
  const auto robot =
      host::load_robot(write("r.yaml", with_colour("    width: 1280\n"
                                                   "    height: 1024\n"
                                                   "    fx: 1050\n"
                                                   "    fy: 1051\n"
                                                   "    cx: 639.5\n"
                                                   "    cy: 511.5\n"
                                                   "    distortion: [0.1, -0.2, 0.001, "
                                                   "0.002, 0.3]\n"
                                                   "    rate_hz: 15\n")),
                       diag);
  ASSERT_TRUE(robot) << diag.format();
  const PinholeModel& k = robot->camera.colour.intrinsics;
  EXPECT_EQ(k.width, 1280);
  EXPECT_EQ(k.height, 1024);
  EXPECT_DOUBLE_EQ(k.fx, 1050.0);
  EXPECT_DOUBLE_EQ(k.fy, 1051.0);
  EXPECT_DOUBLE_EQ(k.cx, 639.5);
  EXPECT_DOUBLE_EQ(k.cy, 511.5);
  EXPECT_EQ(k.distortion, (std::array<double, 5>{0.1, -0.2, 0.001, 0.002, 0.3}));
  EXPECT_DOUBLE_EQ(robot->camera.colour.rate_hz, 15.0);
  // The depth camera's own intrinsics are untouched.
  EXPECT_EQ(robot->camera.intrinsics.width, 640);
  EXPECT_FALSE(robot->camera.intrinsics.has_distortion());
}

// Each field of camera.colour is optional on its own: the others keep the Kinect's values.
TEST_F(RobotLoader, ColourCameraFieldsDefaultOneByOne) {
  host::Diagnostics diag;
  const auto robot =
      host::load_robot(write("r.yaml", with_colour("    fx: 530\n    rate_hz: 25\n")), diag);
  ASSERT_TRUE(robot) << diag.format();
  const ColourCameraSpec defaults;
  const PinholeModel& k = robot->camera.colour.intrinsics;
  EXPECT_DOUBLE_EQ(k.fx, 530.0);
  EXPECT_DOUBLE_EQ(k.fy, defaults.intrinsics.fy);
  EXPECT_EQ(k.width, defaults.intrinsics.width);
  EXPECT_DOUBLE_EQ(k.cx, defaults.intrinsics.cx);
  EXPECT_EQ(k.distortion, defaults.intrinsics.distortion);
  EXPECT_DOUBLE_EQ(robot->camera.colour.rate_hz, 25.0);
}

TEST_F(RobotLoader, StructuredLightValuesAreRead) {
  host::Diagnostics diag;
  const auto robot =
      host::load_robot(write("r.yaml", with_structured_light("  block_px: 8\n"
                                                             "  hold_s: 0.1\n"
                                                             "  exposure_ms: 0\n"
                                                             "  min_correspondences: 12\n"
                                                             "  max_residual_px: 2.5\n")),
                       diag);
  ASSERT_TRUE(robot) << diag.format();
  const StructuredLightSpec& light = robot->structured_light;
  EXPECT_EQ(light.block_px, 8);
  EXPECT_DOUBLE_EQ(light.hold_s, 0.1);
  EXPECT_DOUBLE_EQ(light.exposure_ms, 0.0);
  EXPECT_EQ(light.min_correspondences, 12);
  EXPECT_DOUBLE_EQ(light.max_residual_px, 2.5);
}

// A driver written without params used to get a default-constructed YAML::Node, which is Null
// (as if "params: ~" had been written), not Undefined as PluginInstanceSpec documents.
TEST_F(RobotLoader, Regression_AbsentDriverParamsAreUndefinedNotNull) {
  host::Diagnostics diag;
  const auto robot = host::load_robot(
      write("r.yaml", replace(kRobot, ", params: {port: /dev/ttyUSB0}", "")), diag);
  ASSERT_TRUE(robot) << diag.format();
  const host::PluginInstanceSpec& pan_tilt = robot->drivers.at("pan_tilt");
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

TEST_F(RobotLoader, BadColourCameraValues) {
  const std::vector<BadValue> cases = {
      {"    width: 0\n", "21:12: camera.colour.width: expected an integer > 0, got 0"},
      {"    height: 480.5\n", "21:13: camera.colour.height: expected an integer, got \"480.5\""},
      {"    width: 16384\n", "21:12: camera.colour.width: expected at most 8192 pixels, got 16384"},
      {"    width: 20000\n", "21:12: camera.colour.width: expected at most 8192 pixels, got 20000"},
      {"    fx: -525\n", "21:9: camera.colour.fx: expected a number > 0, got -525"},
      {"    fy: 0\n", "21:9: camera.colour.fy: expected a number > 0, got 0"},
      {"    cx: 700\n",
       "21:9: camera.colour.cx: principal point x 700 lies outside the image [0, 640]"},
      {"    width: 320\n    height: 240\n    cy: 250\n",
       "23:9: camera.colour.cy: principal point y 250 lies outside the image [0, 240]"},
      // A smaller image with the default principal point: reported at the size written.
      {"    width: 300\n",
       "21:12: camera.colour.width: principal point x 319.5 (cx's default) lies outside the "
       "image [0, 300]"},
      {"    cy: centre\n", "21:9: camera.colour.cy: expected a number, got \"centre\""},
      {"    distortion: [0.26, -0.95, 0, 0]\n",
       "21:17: camera.colour.distortion: expected 5 numbers [k1, k2, p1, p2, k3], got 4"},
      {"    distortion: 0\n", "21:17: camera.colour.distortion: expected a list, got \"0\""},
      {"    rate_hz: -30\n", "21:14: camera.colour.rate_hz: expected a number > 0, got -30"},
      {"    fov_deg: 62\n", "21:5: camera.colour.fov_deg: unknown key \"fov_deg\""},
      {"    rate_hz: 30\n    rate_hz: 15\n",
       "22:5: camera.colour.rate_hz: duplicate key \"rate_hz\" (first at line 21)"},
  };
  for (const BadValue& c : cases) {
    SCOPED_TRACE(c.fields);
    EXPECT_THAT(robot_errors(with_colour(c.fields)), ElementsAre(dir + "/r.yaml:" + c.expected));
  }
}

TEST_F(RobotLoader, ColourCameraNotAMapping) {
  EXPECT_THAT(robot_errors(replace(kRobot, "  cy: 239.5\n", "  cy: 239.5\n  colour: kinect\n")),
              ElementsAre(dir + "/r.yaml:20:11: camera.colour: expected a mapping, got "
                                "\"kinect\""));
}

TEST_F(RobotLoader, BadStructuredLightValues) {
  const std::vector<BadValue> cases = {
      {"  block_px: 1\n", "31:13: structured_light.block_px: expected an integer >= 2, got 1"},
      {"  block_px: -16\n", "31:13: structured_light.block_px: expected an integer >= 2, got -16"},
      {"  block_px: 8.5\n", "31:13: structured_light.block_px: expected an integer, got \"8.5\""},
      // The fixture's projector is 1280x800.
      {"  block_px: 1000\n",
       "31:13: structured_light.block_px: block of 1000 px does not fit the projector's "
       "1280x800 image"},
      {"  hold_s: 0\n", "31:11: structured_light.hold_s: expected a number > 0, got 0"},
      {"  hold_s: fast\n", "31:11: structured_light.hold_s: expected a number, got \"fast\""},
      {"  exposure_ms: -1\n",
       "31:16: structured_light.exposure_ms: expected a number >= 0, got -1"},
      {"  min_correspondences: 5\n",
       "31:24: structured_light.min_correspondences: expected an integer >= 6, got 5"},
      {"  min_correspondences: 40.5\n",
       "31:24: structured_light.min_correspondences: expected an integer, got \"40.5\""},
      {"  max_residual_px: 0\n",
       "31:20: structured_light.max_residual_px: expected a number > 0, got 0"},
      {"  blocks_px: 16\n",
       "31:3: structured_light.blocks_px: unknown key \"blocks_px\"; did you mean \"block_px\"?"},
  };
  for (const BadValue& c : cases) {
    SCOPED_TRACE(c.fields);
    EXPECT_THAT(robot_errors(with_structured_light(c.fields)),
                ElementsAre(dir + "/r.yaml:" + c.expected));
  }
}

TEST_F(RobotLoader, StructuredLightNotAMapping) {
  EXPECT_THAT(robot_errors(replace(kRobot, "drivers:", "structured_light: [16]\ndrivers:")),
              ElementsAre(dir + "/r.yaml:30:19: structured_light: expected a mapping, got a "
                                "list"));
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

// The ros2 section (README "ROS 2"): ROS 2's names, QoS, domains; exact diagnostics.
class RobotLoaderRos2 : public RobotLoader {
 protected:
  // The line the appended section's first line lands on.
  int first_line() const {
    const std::string robot = kRobot;
    return static_cast<int>(std::count(robot.begin(), robot.end(), '\n')) + 1 +
           (robot.back() == '\n' ? 0 : 1);
  }
  std::string at(int line_offset, int column) const {
    return dir + "/r.yaml:" + std::to_string(first_line() + line_offset) + ":" +
           std::to_string(column) + ": ";
  }
  std::string with(const std::string& section) const {
    std::string robot = kRobot;
    if (robot.back() != '\n') robot += "\n";
    return robot + section;
  }
};

TEST_F(RobotLoaderRos2, AbsentSectionIsRos2sDefaults) {
  ::unsetenv("ROS_DOMAIN_ID");
  ::unsetenv("ROS_LOCALHOST_ONLY");
  host::Diagnostics diag;
  const auto robot = host::load_robot(dir_path / "robot.yaml", diag);
  ASSERT_TRUE(robot) << diag.format();
  const Ros2Spec& r = robot->ros2;
  EXPECT_FALSE(r.present);
  EXPECT_EQ(r.domain_id, 0);
  EXPECT_FALSE(r.loopback_only);
  EXPECT_EQ(r.ros2_namespace, "");
  EXPECT_EQ(r.cmd_vel.name, "cmd_vel");
  EXPECT_TRUE(r.cmd_vel.reliable);
  EXPECT_EQ(r.cmd_vel.depth, 10);
  EXPECT_EQ(r.odom.name, "odom");
  EXPECT_EQ(r.scan.name, "scan");
  EXPECT_FALSE(r.scan.reliable);  // ROS 2's sensor-data profile
  EXPECT_EQ(r.odom_frame, "odom");
  EXPECT_EQ(r.base_frame, "base_link");
}

TEST_F(RobotLoaderRos2, EnvironmentIsTheDefaultAndTheFileWins) {
  ::setenv("ROS_DOMAIN_ID", "42", 1);
  ::setenv("ROS_LOCALHOST_ONLY", "1", 1);
  host::Diagnostics diag;
  auto robot = host::load_robot(write("r.yaml", with("ros2:\n  namespace: /ud1\n")), diag);
  ASSERT_TRUE(robot) << diag.format();
  EXPECT_TRUE(robot->ros2.present);
  EXPECT_EQ(robot->ros2.domain_id, 42);
  EXPECT_TRUE(robot->ros2.loopback_only);
  robot = host::load_robot(write("r.yaml", with("ros2:\n  domain_id: 7\n  loopback_only: false\n")),
                           diag);
  ASSERT_TRUE(robot) << diag.format();
  EXPECT_EQ(robot->ros2.domain_id, 7);
  EXPECT_FALSE(robot->ros2.loopback_only);
  ::setenv("ROS_DOMAIN_ID", "lots", 1);
  EXPECT_THAT(robot_errors(with("ros2:\n  namespace: /ud1\n")),
              ElementsAre(at(1, 3) + "ros2: environment variable ROS_DOMAIN_ID=\"lots\": expected "
                                     "a DDS domain id from 0 to 232"));
  ::unsetenv("ROS_DOMAIN_ID");
  ::unsetenv("ROS_LOCALHOST_ONLY");
}

TEST_F(RobotLoaderRos2, EveryFieldIsRead) {
  ::unsetenv("ROS_DOMAIN_ID");
  ::unsetenv("ROS_LOCALHOST_ONLY");
  host::Diagnostics diag;
  const auto robot = host::load_robot(
      write("r.yaml",
            with("ros2:\n"
                 "  domain_id: 12\n"
                 "  namespace: /ud1\n"
                 "  loopback_only: true\n"
                 "  topics:\n"
                 "    cmd_vel: {name: base/cmd_vel, reliability: best_effort, depth: 1}\n"
                 "    odom: /odometry/filtered\n"
                 "    scan: {name: front_scan, reliability: reliable}\n"
                 "    joint_states: head/joint_states\n"
                 "    pan_tilt_command: head_controller/commands\n"
                 "  frames: {odom: odom_combined, base: base_footprint, laser: laser_front}\n"
                 "  joints: {pan: head_pan, tilt: head_tilt}\n"
                 "  odom_timeout_s: 0.25\n"
                 "  stop_repeats: 3\n"
                 "  publish_status: false\n")),
      diag);
  ASSERT_TRUE(robot) << diag.format();
  const Ros2Spec& r = robot->ros2;
  EXPECT_EQ(r.domain_id, 12);
  EXPECT_EQ(r.ros2_namespace, "/ud1");
  EXPECT_TRUE(r.loopback_only);
  EXPECT_EQ(r.cmd_vel.name, "base/cmd_vel");
  EXPECT_FALSE(r.cmd_vel.reliable);
  EXPECT_EQ(r.cmd_vel.depth, 1);
  EXPECT_EQ(r.odom.name, "/odometry/filtered");
  EXPECT_EQ(r.scan.name, "front_scan");
  EXPECT_TRUE(r.scan.reliable);
  EXPECT_EQ(r.joint_states.name, "head/joint_states");
  EXPECT_EQ(r.pan_tilt_command.name, "head_controller/commands");
  EXPECT_EQ(r.odom_frame, "odom_combined");
  EXPECT_EQ(r.base_frame, "base_footprint");
  EXPECT_EQ(r.laser_frame, "laser_front");
  EXPECT_EQ(r.pan_joint, "head_pan");
  EXPECT_EQ(r.tilt_joint, "head_tilt");
  EXPECT_DOUBLE_EQ(r.odom_timeout_s, 0.25);
  EXPECT_EQ(r.stop_repeats, 3);
  EXPECT_FALSE(r.publish_status);
}

TEST_F(RobotLoaderRos2, BadValuesNameTheFieldAndWhatWasExpected) {
  ::unsetenv("ROS_DOMAIN_ID");
  EXPECT_THAT(
      robot_errors(with("ros2:\n"
                        "  domain_id: 233\n"
                        "  namespace: ud1\n"
                        "  topics:\n"
                        "    cmd_vel: cmd vel\n"
                        "    odom: {name: odom, depth: 0}\n"
                        "    scan: {name: 2d/scan}\n"
                        "    joint_states: joints//state\n"
                        "    pan_tilt_comand: x\n"
                        "  frames: {odom: /odom}\n"
                        "  joints: {pan: head, tilt: head}\n"
                        "  odom_timeout_s: 0\n")),
      ElementsAre(at(1, 14) + "ros2.domain_id: expected a DDS domain id from 0 to 232, got 233",
                  at(2, 14) + "ros2.namespace: expected a namespace starting with '/' (or \"\"), "
                              "got \"ud1\"",
                  at(8, 5) + "ros2.topics.pan_tilt_comand: unknown key \"pan_tilt_comand\"; did "
                             "you mean \"pan_tilt_command\"?",
                  at(4, 14) + "ros2.topics.cmd_vel: expected a ROS 2 name; \"cmd vel\" has the "
                              "character ' ' (only letters, digits, '_' and '/')",
                  at(5, 31) + "ros2.topics.odom.depth: expected a keep-last depth from 1 to 1000, "
                              "got 0",
                  at(6, 18) + "ros2.topics.scan.name: expected a ROS 2 name; \"2d/scan\" has a "
                              "token starting with a digit (\"2d\")",
                  at(7, 19) + "ros2.topics.joint_states: expected a ROS 2 name; "
                              "\"joints//state\" has an empty token (a doubled or trailing '/')",
                  at(9, 18) + "ros2.frames.odom: expected a ROS 2 name; \"/odom\" must not start "
                              "with '/'",
                  at(10, 11) + "ros2.joints: pan and tilt must be different joints, both are "
                               "\"head\"",
                  at(11, 19) + "ros2.odom_timeout_s: expected a number > 0, got 0"));
}

}  // namespace
}  // namespace projtour::test
