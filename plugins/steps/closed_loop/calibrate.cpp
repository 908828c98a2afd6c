// calibrate: the camera-projector calibration measured on the target. The Gray-code sequence
// goes onto the target area only; each decoded projector block's colour pixel is lifted to 3-D
// with the capture's depth frame registered into the colour camera, and the projector's pose in
// the camera frame is fitted to them (RANSAC, then Levenberg-Marquardt on the reprojection error
// in the projector). A good fit becomes the calibration the rest of the run believes, and a
// robot-file fragment in the run directory; a poor one is an outcome, never a silent fallback.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calibrate.hpp"
#include "projtour/contract/run_image.hpp"
#include "projtour/light/gray_code.hpp"
#include "projtour/light/projector_fit.hpp"
#include "projtour/light/registered_depth.hpp"

namespace projtour::closed_loop {

struct CalibrateSettings {
  int mask_margin_px = 48;
  int roi_margin_px = 24;
  double frame_timeout_s = 1.0;
  double max_change_mm = 60.0;
  double max_change_deg = 5.0;
};

static CalibrateSettings read_settings(const Params& p) {
  CalibrateSettings s;
  s.mask_margin_px = static_cast<int>(p.integer(param::kMaskMarginPx));
  s.roi_margin_px = static_cast<int>(p.integer(param::kRoiMarginPx));
  s.frame_timeout_s = p.number(param::kFrameTimeoutS);
  s.max_change_mm = p.number(param::kMaxChangeMm);
  s.max_change_deg = p.number(param::kMaxChangeDeg);
  if (s.mask_margin_px < 0 || s.mask_margin_px > 400) {
    throw std::invalid_argument("mask_margin_px: must lie in [0, 400]");
  }
  if (s.roi_margin_px < 0 || s.roi_margin_px > 400) {
    throw std::invalid_argument("roi_margin_px: must lie in [0, 400]");
  }
  if (!(s.frame_timeout_s > 0)) throw std::invalid_argument("frame_timeout_s: must be > 0");
  if (!(s.max_change_mm > 0)) throw std::invalid_argument("max_change_mm: must be > 0");
  if (!(s.max_change_deg > 0)) throw std::invalid_argument("max_change_deg: must be > 0");
  return s;
}

namespace {

const char* link_name(Link link) {
  return link == Link::pan ? "pan" : "tilt";
}

// The fragment a person copies into the robot file's projector section to keep the calibration.
void write_fragment(const std::filesystem::path& file, const ProjectorCalibration& c) {
  const Eigen::Vector3d t = c.projector_mount.T_link_body.translation();
  // The robot file's pose: intrinsic Z-Y-X (yaw, then pitch, then roll), as ROS.
  const Eigen::Vector3d ypr = c.projector_mount.T_link_body.linear().eulerAngles(2, 1, 0);
  std::ostringstream s;
  s << "# The projector mount projtour measured by structured light on target " << c.target
    << "\n# at mission time " << fixed(c.t_s, 2) << " s: " << c.inliers << " of "
    << c.correspondences << " projector blocks fitted, RMS " << fixed(c.rms_px, 3)
    << " px in the projector.\n# To keep it, replace the robot file's projector mount and pose "
       "with these lines.\nprojector:\n  mount: "
    << link_name(c.projector_mount.link) << "\n  pose: {x: " << fixed(t.x(), 5)
    << ", y: " << fixed(t.y(), 5) << ", z: " << fixed(t.z(), 5)
    << ", yaw_deg: " << fixed(rad_to_deg(ypr[0]), 4)
    << ", pitch_deg: " << fixed(rad_to_deg(ypr[1]), 4)
    << ", roll_deg: " << fixed(rad_to_deg(ypr[2]), 4) << "}\n";
  make_run_directory(file.parent_path());
  write_run_file(file, s.str());
}

}  // namespace

void check_calibrate_params(const Params& params) {
  read_settings(params);
}

Calibrate::Calibrate(const Params& params, const RunContext& run)
    : settings_(std::make_unique<CalibrateSettings>(read_settings(params))) {
  if (run.mission == nullptr) throw std::invalid_argument("calibrate needs the mission's robot");
  const RobotSpec& robot = run.mission->robot;
  light::GrayCodeSettings gray;
  gray.block_px = robot.structured_light.block_px;
  sequence_ = std::make_unique<light::GrayCodeSequence>(robot.projector.intrinsics, gray);
}

Calibrate::~Calibrate() = default;

void Calibrate::start(Context& ctx) {
  early_.reset();
  view_.reset();
  result_ = CalibrateResult{};
  // The calibration believed so far may put the Model Points just off the image; the sequence
  // needs only enough of the target lit, and verify re-aims with what it measures.
  auto looked = look_at_target(ctx, -1.0);
  if (looked.outcome) {
    early_ = looked.outcome;
    return;
  }
  view_ = std::move(looked.view);
  const RobotSpec& robot = ctx.robot();
  mask_ = projector_mask(*view_, robot.projector.intrinsics, robot.structured_light.block_px,
                         settings_->mask_margin_px);
  const int lit_px = cv::countNonZero(mask_);
  const int block_area_px = robot.structured_light.block_px * robot.structured_light.block_px;
  if (lit_px < robot.structured_light.min_correspondences * block_area_px) {
    early_ =
        Outcome{outcome::kOffScreen,
                target_prefix(ctx) + "the target covers " + std::to_string(lit_px / block_area_px) +
                    " projector blocks, fewer than the " +
                    std::to_string(robot.structured_light.min_correspondences) +
                    " the structured light needs"};
    return;
  }
  capture_.start(
      ctx, *view_, sequence_->size(), [this](int i) { return sequence_->frame(i, mask_); },
      robot.structured_light.hold_s, robot.structured_light.exposure_ms);
}

std::optional<Outcome> Calibrate::tick(Context& ctx) {
  if (early_) return early_;
  if (auto ended = capture_.step(ctx, settings_->frame_timeout_s, "the structured light")) {
    return ended;
  }
  if (!capture_.done()) return std::nullopt;
  const Outcome outcome = measure(ctx);
  publish(ctx);
  return outcome;
}

void Calibrate::publish(Context& ctx) const {
  ctx.blackboard().set(keys::kCalibrate, result_);
}

Outcome Calibrate::measure(Context& ctx) {
  const std::string who = target_prefix(ctx);
  const RobotSpec& robot = ctx.robot();
  const StructuredLightSpec& sl = robot.structured_light;
  const auto started = std::chrono::steady_clock::now();
  result_.sequence_s = capture_.duration_s();

  const PinholeModel& colour = robot.camera.colour.intrinsics;
  const light::DecodeResult decoded = light::decode(
      *sequence_, capture_.frames(), colour_roi(*view_, colour, settings_->roi_margin_px));
  const light::RegisteredDepth depth = light::register_depth(
      capture_.lift_depth(view_->capture->frame), robot.camera.depth_to_color_m, colour);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  for (const light::BlockCorrespondence& b : decoded.blocks) {
    if (const auto p = light::lift(depth, b.colour_px)) {
      points.push_back(*p);
      pixels.push_back(b.projector_px);
    }
  }
  result_.decoded_blocks = static_cast<int>(points.size());
  const auto elapsed_ms = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started)
        .count();
  };
  if (result_.decoded_blocks < sl.min_correspondences) {
    result_.compute_ms = elapsed_ms();
    std::string detail = decoded.problem.empty() ? "" : " (" + decoded.problem + ")";
    return Outcome{outcome::kTooFewPoints,
                   who + "the structured light decoded " + std::to_string(result_.decoded_blocks) +
                       " projector blocks on the target with depth, fewer than the " +
                       std::to_string(sl.min_correspondences) + " needed" + detail +
                       "; keeping the calibration believed so far"};
  }
  light::FitSettings fit_settings;
  fit_settings.min_inliers = sl.min_correspondences;
  const light::ProjectorFit fit = light::fit_projector_pose(
      points, pixels, robot.projector.intrinsics, view_->T_projector_camera, fit_settings);
  result_.compute_ms = elapsed_ms();
  result_.inliers = fit.inliers;
  result_.rms_px = fit.rms_px;
  if (!fit.T_projector_camera) {
    return Outcome{outcome::kPoorFit, who + "no camera-projector fit: " + fit.problem +
                                          "; keeping the calibration believed so far"};
  }
  // How far the measurement moves the content on this target, at the Model Points.
  double change_m = 0.0;
  for (const Eigen::Vector3d& p : view_->model_points_camera) {
    change_m =
        std::max(change_m, ((*fit.T_projector_camera) * p - view_->T_projector_camera * p).norm());
  }
  result_.change_mm = change_m * 1e3;
  result_.change_deg =
      rad_to_deg(rotation_angle_rad(*fit.T_projector_camera, view_->T_projector_camera));
  std::ostringstream figures;
  figures << fit.inliers << " of " << points.size() << " blocks, RMS " << fixed(fit.rms_px, 2)
          << " px, moves the content " << fixed(result_.change_mm, 1) << " mm / "
          << fixed(result_.change_deg, 2) << " deg";
  if (fit.rms_px > sl.max_residual_px) {
    return Outcome{outcome::kPoorFit, who + "camera-projector fit too loose (" + figures.str() +
                                          "; RMS limit " + fixed(sl.max_residual_px, 2) +
                                          " px); keeping the calibration believed so far"};
  }
  if (result_.change_mm > settings_->max_change_mm ||
      result_.change_deg > settings_->max_change_deg) {
    return Outcome{outcome::kPoorFit, who + "the fit moves the calibration implausibly far (" +
                                          figures.str() + "; limits " +
                                          fixed(settings_->max_change_mm, 0) + " mm / " +
                                          fixed(settings_->max_change_deg, 1) +
                                          " deg); keeping the calibration believed so far"};
  }
  ProjectorCalibration calibration;
  calibration.projector_mount =
      view_->kinematics->projector_mount_for(view_->joints, *fit.T_projector_camera);
  calibration.T_projector_camera = *fit.T_projector_camera;
  calibration.joints = view_->joints;
  calibration.target = ctx.target->id;
  calibration.t_s = ctx.now_s();
  calibration.correspondences = static_cast<int>(points.size());
  calibration.inliers = fit.inliers;
  calibration.rms_px = fit.rms_px;
  ctx.blackboard().set(keys::kCalibration, calibration);
  result_.adopted = true;
  if (!ctx.run->run_dir.empty()) {
    try {
      write_fragment(ctx.run->run_dir / "calibration.yaml", calibration);
    } catch (const std::exception& e) {
      ctx.log().warning(who + "calibration adopted but not written: " + e.what());
    }
  }
  return Outcome{outcome::kSucceeded, who + "calibrated by structured light: " + figures.str()};
}

}  // namespace projtour::closed_loop
