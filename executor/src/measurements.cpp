#include "projtour_executor/measurements.hpp"

#include <array>
#include <optional>

#include "projtour/blackboard_keys.hpp"
#include "projtour/geometry.hpp"
#include "projtour/ground_truth.hpp"

namespace projtour {

namespace {

void measure_navigate(const Context& ctx, GroundTruth* truth, TargetMeasurements& out) {
  if (truth == nullptr) return;
  const auto estimate = ctx.blackboard().get<PoseEstimate2D>(keys::kLocalization);
  if (!estimate) return;
  // Both on the floor plane: the estimate has no z, roll or pitch.
  const Eigen::Isometry3d T_map_base_true =
      isometry_from_pose2d(pose2d_from_isometry(truth->true_T_map_base()));
  const Eigen::Isometry3d T_map_base = isometry_from_pose2d(estimate->mean);
  out.localization_error =
      LocalizationError{translation_distance_m(T_map_base, T_map_base_true),
                        rad_to_deg(rotation_angle_rad(T_map_base, T_map_base_true))};
}

void measure_align(const Context& ctx, GroundTruth* truth, TargetMeasurements& out) {
  const Blackboard& bb = ctx.blackboard();
  if (const auto quality = bb.get<keys::AlignQuality>(keys::kAlignQuality)) {
    out.align = AlignFigures{quality->method, quality->time_ms, quality->iterations,
                             quality->inlier_fraction, quality->rmse_mm};
  }
  if (truth == nullptr || ctx.target == nullptr) return;
  const auto T_camera_model = bb.get<Eigen::Isometry3d>(keys::kTCameraModel);
  if (!T_camera_model) return;
  const Eigen::Isometry3d T_camera_model_true =
      truth->true_T_map_camera().inverse() * truth->true_T_map_model(ctx.target->id);
  out.target_pose_error =
      TargetPoseError{1000.0 * translation_distance_m(*T_camera_model, T_camera_model_true),
                      rad_to_deg(rotation_angle_rad(*T_camera_model, T_camera_model_true))};
}

void measure_project(const Context& ctx, GroundTruth* truth, TargetMeasurements& out) {
  const Blackboard& bb = ctx.blackboard();
  if (const auto shown_s = bb.get<double>(keys::kProjectedSeconds)) out.projected_s = *shown_s;
  if (truth == nullptr || ctx.target == nullptr) return;
  using Pixels = std::array<Eigen::Vector2d, 4>;
  const auto before = bb.get<Pixels>(keys::kPixelsBeforeAlign);
  const auto after = bb.get<Pixels>(keys::kPixelsAfterAlign);
  BeforeAfter mm, px;
  const auto evaluate = [&](const auto& pixels, std::optional<double> BeforeAfter::*field) {
    if (!pixels) return;
    if (const auto error = truth->evaluate_projection(ctx.target->id, *pixels)) {
      mm.*field = error->mean_mm();
      px.*field = error->mean_px();
    }
  };
  evaluate(before, &BeforeAfter::before_align);
  evaluate(after, &BeforeAfter::after_align);
  if (mm.before_align || mm.after_align) {
    out.projection_error_mm = mm;
    out.projection_error_px = px;
  }
  if (before && after && !ctx.target_dir.empty()) {
    truth->write_projection_views(ctx.target->id, *before, *after, ctx.target_dir);
  }
}

}  // namespace

void measure_on_exit(const std::string& kind, const Context& ctx,
                     TargetMeasurements& measurements) {
  if (kind != "navigate" && kind != "align" && kind != "project") return;
  try {
    GroundTruth* truth = ctx.run->dry_run && ctx.run->drivers != nullptr
                             ? ctx.run->drivers->ground_truth()
                             : nullptr;
    if (kind == "navigate") measure_navigate(ctx, truth, measurements);
    if (kind == "align") measure_align(ctx, truth, measurements);
    if (kind == "project") measure_project(ctx, truth, measurements);
  } catch (const std::exception& e) {
    if (ctx.run->log != nullptr) {
      ctx.run->log->warning("measuring " + kind + " of " + ctx.state_path + ": " + e.what());
    }
  }
}

}  // namespace projtour
