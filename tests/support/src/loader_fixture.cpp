#include "projtour_test/loader_fixture.hpp"

#include <stdlib.h>

#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "projtour/host/mission_loader.hpp"

namespace projtour::test {

const char* const kMission = R"(mission: atrium-spring-sale
map: map.yaml
robot: robot.yaml
start: {x: 1.0, y: 1.5, yaw_deg: 90}
targets:
  - id: rabbit
    model: bunny.ply
    pose: {x: 6.0, y: 2.0, z: 0.9, yaw_deg: 180}
    model_points: [[0.1225, 0.0, 0.08], [0.1215, 0.06, 0.08], [0.089, 0.06, -0.02], [0.1153, 0.0, -0.02]]
    content: sale.png
    standoff_m: 1.2
    dwell_s: 15
  - id: hare
    model: bunny.ply
    pose: {x: 2.0, y: 4.0, z: 0.5, yaw_deg: -90, roll_deg: 0, pitch_deg: 0}
    model_points: [[0.1, 0.0, 0.1], [0.1, 0.1, 0.1], [0.1, 0.1, 0.0], [0.1, 0.0, 0.0]]
    content: sale.png
machine: default
)";

const char* const kRobot = R"(robot: test-bot
base: {radius_m: 0.3}
laser:
  pose: {x: 0.2, y: 0, z: 0.3, yaw_deg: 0}
pan_tilt:
  pan_joint: {pose: {x: 0, y: 0, z: 1.0, yaw_deg: 0}}
  tilt_joint: {pose: {x: 0, y: 0, z: 0.1, yaw_deg: 0}}
  pan_limits_deg: [-170, 170]
  tilt_limits_deg: [-30, 60]
  stow: {pan_deg: 0, tilt_deg: 0}
camera:
  mount: pan
  pose: {x: 0.08, y: 0, z: 0.25, yaw_deg: 0, pitch_deg: 20}
  width: 640
  height: 480
  fx: 525
  fy: 525
  cx: 319.5
  cy: 239.5
projector:
  mount: tilt
  pose: {x: 0.1, y: 0, z: 0, yaw_deg: 0}
  width: 1280
  height: 800
  fx: 1920
  fy: 1920
  cx: 640
  cy: 400
  distortion: [0.01, -0.005, 0, 0, 0]
drivers:
  pan_tilt: {kind: ptu_dperception, params: {port: /dev/ttyUSB0}}
)";

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "fixture text lacks \"" << from << "\"";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::vector<std::string> formatted(const host::Diagnostics& diag) {
  std::vector<std::string> out;
  for (const auto& d : diag.items()) out.push_back(d.format());
  return out;
}

void LoaderTest::SetUp() {
  scratch_.emplace();
  dir_path = scratch_->path();
  dir = dir_path.string();
  write("map.yaml", "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n");
  write("bunny.ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
  write("robot.yaml", kRobot);
  ASSERT_TRUE(cv::imwrite(dir + "/sale.png", cv::Mat(8, 8, CV_8UC3, cv::Scalar(0, 128, 255))));
}

void LoaderTest::TearDown() {
  scratch_.reset();
}

std::string LoaderTest::write(const std::string& name, const std::string& text) const {
  const std::filesystem::path path = dir_path / name;
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

std::vector<std::string> LoaderTest::mission_errors(const std::string& text) const {
  host::Diagnostics diag;
  EXPECT_FALSE(host::load_mission(write("m.yaml", text), diag));
  EXPECT_TRUE(diag.has_errors());
  return formatted(diag);
}

std::vector<std::string> LoaderTest::robot_errors(const std::string& text) const {
  host::Diagnostics diag;
  EXPECT_FALSE(host::load_robot(write("r.yaml", text), diag));
  EXPECT_TRUE(diag.has_errors());
  return formatted(diag);
}

}  // namespace projtour::test
