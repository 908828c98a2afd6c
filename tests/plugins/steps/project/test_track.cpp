// Live re-alignment in a dry run: the simulator's drivers and the capture, align and project
// behaviours, loaded as plugins the way the executor loads them. The robot stands in front of the
// bunny, aligns, projects, and the simulator nudges the target 2 cm sideways during the dwell.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/head/projection.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/perception/model.hpp"
#include "projtour_test/run_rig.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

constexpr double kFramePeriodS = 1.0 / 30.0;  // the UD's Kinect; the test ticks once a frame
constexpr double kNudgeM = 0.02;
constexpr double kNudgeAfterS = 1.0;
constexpr double kDwellS = 2.5;

fs::path write_content(const fs::path& dir) {
  cv::Mat image(300, 400, CV_8UC3, cv::Scalar(30, 160, 230));
  cv::putText(image, "SALE", {70, 190}, cv::FONT_HERSHEY_SIMPLEX, 3.0, cv::Scalar(255, 255, 255),
              8);
  const fs::path file = dir / "content.png";
  if (!cv::imwrite(file.string(), image)) throw std::runtime_error("cannot write content");
  return file;
}

// Model Points on the mesh (vertices): a 4 x 4 cm patch of the rabbit's chest, flat enough that
// a 2 cm sideways nudge keeps the rays on it. Corners as seen from the front, where the model's
// +y is the viewer's right.
head::Quad3d chest_quad(const perception::TriangleMesh& mesh) {
  const std::array<Eigen::Vector2d, 4> yz = {
      Eigen::Vector2d(0.0, 0.09), Eigen::Vector2d(0.04, 0.09), Eigen::Vector2d(0.04, 0.05),
      Eigen::Vector2d(0.0, 0.05)};
  head::Quad3d quad;
  for (int i = 0; i < 4; ++i) {
    // The frontmost vertex near the wanted (y, z) lies on the surface the robot faces.
    std::optional<Eigen::Vector3d> best;
    for (const Eigen::Vector3f& v : mesh.vertices) {
      if ((Eigen::Vector2d(v.y(), v.z()) - yz[i]).norm() > 0.006) continue;
      if (!best || v.x() > best->x()) best = v.cast<double>();
    }
    if (!best) throw std::runtime_error("no bunny vertex near a wanted Model Point");
    quad[i] = *best;
  }
  return quad;
}

// What the projection looked like after each project tick.
struct Shown {
  double t_s = 0.0;
  bool nudged = false;  // the true target has moved by then
  bool lit = false;
  double error_mm = 0.0;
  double tick_ms = 0.0;  // wall time of the tick (tracking: the frame's render + align + warp)
};

// One dry run: a mission of one bunny target, the world (nudge fault), the five sim drivers.
class DryRun {
 public:
  // `exact_calibration`: the robot's camera-projector calibration is the truth (no error), so
  // what remains is the alignment's and the tracking's own error.
  DryRun(const std::string& /*name: the caller's label; the rig's directory is per test*/,
         bool exact_calibration) {
    for (const char* plugin : {"sim", "capture", "align", "project"}) {
      registry.load_library(fs::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                            ("libprojtour_" + std::string(plugin) + ".so"));
    }
    host::Diagnostics diag;
    auto robot = host::load_robot(fs::path(PROJTOUR_SOURCE_DIR) / "examples/robot/ud.yaml", diag);
    if (!robot) throw std::runtime_error("cannot load examples/robot/ud.yaml");
    mission.name = "track-test";
    mission.robot = *robot;
    TargetSpec target;
    target.id = "rabbit";
    target.model = fs::path(PROJTOUR_SOURCE_DIR) / "examples/models/bunny.ply";
    target.T_map_model = isometry_from_xyz_rpy(3.0, 0.0, 0.9, 0.0, 0.0, kPi);
    target.model_points = chest_quad(perception::load_mesh(target.model));
    target.content = write_content(dir_);
    target.dwell_s = kDwellS;
    mission.targets.push_back(target);
    // Already at the stand-off pose, as navigate leaves it.
    mission.start = navigation::standoff_pose(target);
    // The world file as a dry run reads it. The nudge is sideways to the robot's view (the
    // robot looks along the map's +x), kNudgeAfterS after the projector first lights the target.
    const fs::path world_file = dir_ / "world.yaml";
    std::ofstream(world_file)
        << (exact_calibration ? "calibration_error: {trans_mm: 0, rot_deg: 0}\n" : "")
        << "faults:\n  - {target: rabbit, type: target_nudge, after_s: " << kNudgeAfterS
        << ", distance_m: " << kNudgeM << ", direction_deg: 90}\n";
    auto loaded = host::load_world(world_file, mission, diag);
    if (!loaded) throw std::runtime_error("cannot load the world file: " + diag.format());
    world = *loaded;

    rig.use_world();
    run.seed = 5;
    drivers.base = driver<BaseDriver>("sim_base");
    drivers.laser = driver<LaserDriver>("sim_laser");
    drivers.pan_tilt = driver<PanTiltDriver>("sim_pan_tilt");
    drivers.depth_camera = driver<DepthCameraDriver>("sim_depth_camera");
    drivers.projector = driver<ProjectorDriver>("sim_projector", {{"log_file", std::string()}});
    truth = drivers.ground_truth();
    if (truth == nullptr) throw std::runtime_error("the sim drivers know no truth");
    ctx = rig.context();
    ctx.target = &mission.targets[0];
    ctx.target_dir = dir_;
    // Localization at the truth: this test is about the camera-projector path, not the base.
    PoseEstimate2D localization;
    localization.mean = mission.start;
    blackboard.set(keys::kLocalization, localization);
    step();
  }

  // One tick of mission time: every driver updates (the world advances once), as the executor.
  void step() {
    clock.set(static_cast<double>(ticks_++) * kFramePeriodS);
    for (const auto& d : drivers.all()) d->update(clock.now_s());
  }

  std::shared_ptr<Behaviour> make(const std::string& kind,
                                  const std::map<std::string, ParamValue>& values = {}) {
    auto params = std::make_unique<Params>(host::default_params(registry.require(kind).params));
    for (const auto& [name, value] : values) params->set(name, value);
    EXPECT_EQ(registry.validate_params(kind, *params), "");
    auto b = registry.create_behaviour(kind, *params, run);
    params_.push_back(std::move(params));
    return b;
  }

  // start, then tick once a frame until an outcome; `after_tick` sees the world after each tick.
  Outcome run_behaviour(Behaviour& b, const std::function<void()>& after_tick = {}) {
    b.start(ctx);
    for (int i = 0; i < 2000; ++i) {
      step();
      const std::optional<Outcome> outcome = b.tick(ctx);
      if (after_tick) after_tick();
      if (outcome) {
        b.stop(ctx);
        return *outcome;
      }
    }
    b.stop(ctx);
    return {"(still running)", ""};
  }

  // The head as aim leaves it: the projector's axis through the Model Points' centre.
  void aim() {
    const TargetSpec& target = mission.targets[0];
    Eigen::Vector3d centre_model = Eigen::Vector3d::Zero();
    for (const auto& p : target.model_points) centre_model += p / 4.0;
    const Eigen::Vector3d p_base =
        isometry_from_pose2d(mission.start).inverse() * (target.T_map_model * centre_model);
    std::string why;
    const auto q = head::HeadKinematics(mission.robot).aim_projector_at(p_base, &why);
    if (!q) throw std::runtime_error("cannot aim: " + why);
    drivers.pan_tilt->command(*q);
    for (int i = 0; i < 300 && !drivers.pan_tilt->reached(); ++i) step();
    if (!drivers.pan_tilt->reached()) throw std::runtime_error("the head did not reach the aim");
  }

  // Capture and align as the tour does; then project, recording the truth after every tick.
  std::vector<Shown> aim_align_project(
      bool track, const std::map<std::string, ParamValue>& project_params = {}) {
    aim();
    auto capture = make("capture");
    const Outcome captured = run_behaviour(*capture);
    EXPECT_EQ(captured.name, "succeeded") << captured.message;
    auto align = make("align", {{"draw", false}});
    const Outcome aligned = run_behaviour(*align);
    EXPECT_EQ(aligned.name, "succeeded") << aligned.message;

    const Eigen::Isometry3d T_map_model_before = truth->true_T_map_model("rabbit");
    projection_started_s = clock.now_s();
    std::vector<Shown> shown;
    std::map<std::string, ParamValue> params = project_params;
    params["track"] = track;
    auto project = make("project", params);
    auto tick_started = std::chrono::steady_clock::now();
    const Outcome projected = run_behaviour(*project, [&] {
      Shown s;
      s.tick_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tick_started)
              .count();
      s.t_s = clock.now_s();
      s.nudged =
          translation_distance_m(truth->true_T_map_model("rabbit"), T_map_model_before) > 1e-6;
      s.lit = !drivers.projector->is_blank();
      const ProjectResult* result = blackboard.find(keys::kProject);
      EXPECT_TRUE(result != nullptr && result->pixels_after_align);
      if (result == nullptr || !result->pixels_after_align) return;
      s.error_mm = truth->evaluate_projection("rabbit", *result->pixels_after_align)->mean_mm();
      shown.push_back(s);
      tick_started = std::chrono::steady_clock::now();
    });
    EXPECT_EQ(projected.name, "succeeded") << projected.message;
    // The visit's tracking figures travel in its outcome, so events.jsonl has them per target.
    if (track) {
      EXPECT_NE(projected.message.find("; tracking: "), std::string::npos) << projected.message;
      EXPECT_NE(projected.message.find("per frame median"), std::string::npos) << projected.message;
      EXPECT_NE(projected.message.find("the work besides capture median"), std::string::npos)
          << projected.message;
    } else {
      EXPECT_EQ(projected.message.find("tracking"), std::string::npos) << projected.message;
    }
    return shown;
  }

  // First, so it is destroyed last: blackboard values set by a plugin keep code of that plugin.
  host::PluginRegistry registry;
  test::RunRig rig;
  MissionSpec& mission = rig.mission;
  host::WorldSpec& world = rig.world;
  RunContext& run = rig.run;
  DriverSet& drivers = rig.drivers;
  Blackboard& blackboard = rig.blackboard;
  SteppedClock& clock = rig.clock;
  test::RecordingLogger& log = rig.log;
  Context ctx;
  GroundTruth* truth = nullptr;
  double projection_started_s = 0.0;

 private:
  template <typename D>
  std::shared_ptr<D> driver(const std::string& kind,
                            const std::map<std::string, ParamValue>& values = {}) {
    Params params = host::default_params(registry.require(kind).params);
    for (const auto& [name, value] : values) params.set(name, value);
    auto d = std::dynamic_pointer_cast<D>(registry.create_driver(kind, params, run));
    if (!d) throw std::runtime_error(kind + " is not the driver expected");
    return d;
  }

  const fs::path dir_ = rig.run.run_dir;
  long long ticks_ = 0;
  std::vector<std::unique_ptr<Params>> params_;
};

double mean_error_mm(std::vector<Shown>::const_iterator from,
                     std::vector<Shown>::const_iterator to) {
  double sum = 0.0;
  for (auto it = from; it != to; ++it) sum += it->error_mm;
  return from == to ? -1.0 : sum / static_cast<double>(std::distance(from, to));
}

std::vector<Shown>::const_iterator first_nudged(const DryRun& dry,
                                                const std::vector<Shown>& shown) {
  const auto nudge =
      std::find_if(shown.begin(), shown.end(), [](const Shown& s) { return s.nudged; });
  if (nudge != shown.end()) {
    // The fault acts kNudgeAfterS after the projector first lit the target.
    EXPECT_NEAR(nudge->t_s, dry.projection_started_s + kNudgeAfterS, 1.5 * kFramePeriodS);
  }
  return nudge;
}

// Camera frames from the first that sees the moved target to the first whose projection error
// is under `bar_mm` (1: corrected at once), or -1 when it never is.
long frames_until_under(std::vector<Shown>::const_iterator nudge, const std::vector<Shown>& shown,
                        double bar_mm) {
  const auto back =
      std::find_if(nudge, shown.end(), [&](const Shown& s) { return s.error_mm < bar_mm; });
  return back == shown.end() ? -1 : std::distance(nudge, back) + 1;
}

std::string tracking_summary(const DryRun& dry) {
  for (const std::string& line : dry.log.messages()) {
    if (line.find("tracking:") != std::string::npos) return line;
  }
  return "";
}

double median_tick_ms(std::vector<Shown>::const_iterator from,
                      std::vector<Shown>::const_iterator to) {
  std::vector<double> ms;
  for (auto it = from; it != to; ++it) ms.push_back(it->tick_ms);
  if (ms.empty()) return 0.0;
  std::nth_element(ms.begin(), ms.begin() + static_cast<std::ptrdiff_t>(ms.size() / 2), ms.end());
  return ms[ms.size() / 2];
}

TEST(Track, NudgedTargetIsMappedAgainWithinFiveFrames) {
  DryRun dry("exact", /*exact_calibration=*/true);
  const std::vector<Shown> shown = dry.aim_align_project(/*track=*/true);
  const auto nudge = first_nudged(dry, shown);
  ASSERT_NE(nudge, shown.end()) << "the simulator never nudged the target";

  // Before the nudge the tracked projection sits on the Model Points.
  for (auto it = shown.begin(); it != nudge; ++it) {
    EXPECT_LT(it->error_mm, 3.0) << "at t = " << it->t_s << " s, before the nudge";
  }
  const long frames = frames_until_under(nudge, shown, 3.0);
  ASSERT_GT(frames, 0) << "the projection never came back under 3 mm";
  EXPECT_LE(frames, 5);
  // ... and it stays there for the rest of the dwell, with the projector lit throughout.
  const auto back = nudge + (frames - 1);
  for (auto it = back; it != shown.end(); ++it) {
    EXPECT_LT(it->error_mm, 3.0) << "at t = " << it->t_s << " s, after recovering";
  }
  for (auto it = shown.begin(); it + 1 != shown.end(); ++it) {
    EXPECT_TRUE(it->lit) << "the projector went dark while tracking, at t = " << it->t_s << " s";
  }
  const std::string summary = tracking_summary(dry);
  EXPECT_NE(summary, "") << "project logs no tracking summary";
  std::cout << "[ track    ] exact calibration: " << mean_error_mm(shown.begin(), nudge)
            << " mm before the nudge; the first frame after it shows " << nudge->error_mm
            << " mm; under 3 mm after " << frames << " frame(s); then "
            << mean_error_mm(back, shown.end()) << " mm on average\n"
            << "[ track    ] median project tick " << median_tick_ms(shown.begin(), shown.end())
            << " ms (the simulator's depth render included)\n[ track    ] " << summary << "\n";
}

// With the world's default calibration error (1 mm, 0.1 deg) the error floor is that
// calibration's, which no re-alignment removes: the nudge's part must still go within 5 frames.
TEST(Track, WithCalibrationErrorTheNudgeIsUndoneWithinFiveFrames) {
  DryRun dry("default", /*exact_calibration=*/false);
  const std::vector<Shown> shown = dry.aim_align_project(/*track=*/true);
  const auto nudge = first_nudged(dry, shown);
  ASSERT_NE(nudge, shown.end()) << "the simulator never nudged the target";
  const double before_mm = mean_error_mm(shown.begin(), nudge);
  const long frames = frames_until_under(nudge, shown, before_mm + 1.0);
  ASSERT_GT(frames, 0) << "the projection never came back near its error before the nudge";
  EXPECT_LE(frames, 5);
  const double after_mm = mean_error_mm(nudge + (frames - 1), shown.end());
  EXPECT_LT(after_mm, before_mm + 1.0);
  std::cout << "[ track    ] default calibration error: " << before_mm
            << " mm before the nudge, back within 1 mm of it after " << frames << " frame(s), then "
            << after_mm << " mm on average\n[ track    ] " << tracking_summary(dry) << "\n";
}

TEST(Track, WithoutTrackingTheNudgeStaysAsProjectionError) {
  DryRun dry("off", /*exact_calibration=*/true);
  const std::vector<Shown> shown = dry.aim_align_project(/*track=*/false);
  const auto nudge = first_nudged(dry, shown);
  ASSERT_NE(nudge, shown.end()) << "the simulator never nudged the target";
  const double before_mm = mean_error_mm(shown.begin(), nudge);
  const double after_mm = mean_error_mm(nudge, shown.end());
  EXPECT_LT(before_mm, 3.0);
  // The content stays where the target was: off by about the nudge.
  EXPECT_NEAR(after_mm, kNudgeM * 1e3, 5.0);
  EXPECT_EQ(tracking_summary(dry), "");
  std::cout << "[ track    ] without tracking: " << before_mm << " mm before the nudge, "
            << after_mm << " mm after\n";
}

// Frames that fail the quality gate never move the content: with a gate no fit can pass, the
// nudge stays uncorrected and the log says why.
TEST(Track, FramesFailingTheGateAreNotFollowed) {
  DryRun dry("gate", /*exact_calibration=*/true);
  const std::vector<Shown> shown =
      dry.aim_align_project(/*track=*/true, {{"track_min_inlier_fraction", 1.0}});
  const auto nudge = first_nudged(dry, shown);
  ASSERT_NE(nudge, shown.end()) << "the simulator never nudged the target";
  EXPECT_NEAR(mean_error_mm(nudge, shown.end()), kNudgeM * 1e3, 5.0);
  const std::string summary = tracking_summary(dry);
  EXPECT_NE(summary.find(" 0 passed the gate, 0 re-warps"), std::string::npos) << summary;
  const std::vector<std::string> lines = dry.log.messages();
  const bool warned = std::any_of(lines.begin(), lines.end(), [](const auto& l) {
    return l.find("frames in a row failed the tracking gate") != std::string::npos;
  });
  EXPECT_TRUE(warned);
}

TEST(Track, ParametersAreCheckedAtLoad) {
  host::PluginRegistry registry;
  registry.load_library(fs::path(PROJTOUR_PLUGIN_BUILD_DIR) / "libprojtour_project.so");
  const auto with = [&](const std::string& name, ParamValue value) {
    Params p = host::default_params(registry.require("project").params);
    p.set("track", true);
    p.set(name, value);
    return registry.validate_params("project", p);
  };
  EXPECT_EQ(with("track_threshold_mm", 1.0), "");
  EXPECT_NE(with("track_threshold_mm", -1.0).find("track_threshold_mm"), std::string::npos);
  EXPECT_NE(with("track_min_inlier_fraction", 1.5).find("track_min_inlier_fraction"),
            std::string::npos);
}

}  // namespace
}  // namespace projtour
