// libFuzzer harness: any text through load_mission_from_string must come back as a MissionSpec
// or as diagnostics; never a crash, a sanitizer report or an exception.
//
// Every path a mission names is resolved against a sandbox directory this harness creates and
// fills with valid map, robot, model, content and machine files. Inputs holding '/' or '\' are
// skipped: without them (YAML escapes need a backslash) no path can leave the sandbox, so the
// fuzzer only ever reads the files below.
#include <stdlib.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "projtour/host/mission_loader.hpp"

namespace {

const char* const kRobot = R"(robot: fuzz-bot
base: {radius_m: 0.3}
laser: {pose: {x: 0.2, y: 0, z: 0.3, yaw_deg: 0}}
pan_tilt:
  pan_joint: {pose: {x: 0, y: 0, z: 1.0, yaw_deg: 0}}
  tilt_joint: {pose: {x: 0, y: 0, z: 0.1, yaw_deg: 0}}
  pan_limits_deg: [-170, 170]
  tilt_limits_deg: [-30, 60]
camera: {mount: pan, pose: {x: 0, y: 0, z: 0.2, yaw_deg: 0}, width: 640, height: 480, fx: 525, fy: 525, cx: 319.5, cy: 239.5, colour: {width: 640, cx: 319.5, distortion: [0.26, -0.95, 0, 0, 1.16]}}
projector: {mount: tilt, pose: {x: 0.1, y: 0, z: 0, yaw_deg: 0}, width: 1280, height: 800, fx: 1920, fy: 1920, cx: 640, cy: 400}
structured_light: {block_px: 16, hold_s: 0.05, min_correspondences: 40}
)";

void write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

class Sandbox {
 public:
  Sandbox() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "projtour_fuzz_XXXXXX").string();
    if (!mkdtemp(pattern.data())) abort();
    dir_ = pattern;
    write(dir_ / "map.yaml", "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n");
    write(dir_ / "robot.yaml", kRobot);
    write(dir_ / "bunny.ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
    write(dir_ / "clip.mp4", "video");
    write(dir_ / "tour.yaml", "initial: go\nstates: {go: {behaviour: navigate}}\n");
    write(dir_ / "list.yaml", "- a\n- b\n");
    write(dir_ / "broken.png", "not a png");
    if (!cv::imwrite((dir_ / "sale.png").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)))) {
      abort();
    }
  }
  ~Sandbox() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Sandbox sandbox;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (text.find_first_of("/\\") != std::string::npos) return 0;

  projtour::host::Diagnostics diag;
  const auto mission =
      projtour::host::load_mission_from_string(text, sandbox.dir() / "mission.yaml", diag);
  // The promise of the API: a mission exactly when no error was recorded.
  if (mission.has_value() == diag.has_errors()) abort();
  const std::string report = diag.format();
  if (diag.has_errors() && report.empty()) abort();
  if (mission) {
    for (const auto& target : mission->targets) {
      if (target.id.empty() || !std::filesystem::exists(target.model)) abort();
    }
  }
  return 0;
}
