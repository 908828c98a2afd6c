#include "projtour/record/measurements.hpp"

#include <array>
#include <cmath>
#include <cstddef>
#include <optional>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/ground_truth.hpp"

namespace projtour {

namespace {

// Where the robot believed it was when navigate ended (arrived, or gave up).
void measure_navigate(const Context& ctx, const NavigateResult& result, GroundTruth* truth,
                      TargetMeasurements& out) {
  if (!result.planned_path.empty()) {
    double length_m = 0.0;
    for (std::size_t i = 1; i < result.planned_path.size(); ++i) {
      const Pose2D& a = result.planned_path[i - 1];
      const Pose2D& b = result.planned_path[i];
      length_m += std::hypot(b.x_m - a.x_m, b.y_m - a.y_m);
    }
    out.planned_path_m = length_m;
  }
  if (truth == nullptr) return;
  const PoseEstimate2D* estimate =
      result.arrived_at ? &*result.arrived_at : ctx.blackboard().find(keys::kLocalization);
  if (estimate == nullptr) return;
  // Both on the floor plane: the estimate has no z, roll or pitch.
  const auto on_floor = [](const Eigen::Isometry3d& T) {
    return isometry_from_pose2d(pose2d_from_isometry(T));
  };
  const Eigen::Isometry3d T_map_base = isometry_from_pose2d(estimate->mean);
  const Eigen::Isometry3d T_drawn = on_floor(truth->true_T_map_base_as_drawn());
  const Eigen::Isometry3d T_building = on_floor(truth->true_T_map_base());
  LocalizationError e{translation_distance_m(T_map_base, T_drawn),
                      rad_to_deg(rotation_angle_rad(T_map_base, T_drawn)), std::nullopt,
                      std::nullopt};
  if (!T_drawn.isApprox(T_building, 1e-12)) {
    e.building_trans_m = translation_distance_m(T_map_base, T_building);
    e.building_rot_deg = rad_to_deg(rotation_angle_rad(T_map_base, T_building));
  }
  out.localization_error = e;
}

void measure_align(const Context& ctx, const AlignResult& result, GroundTruth* truth,
                   TargetMeasurements& out) {
  if (const auto& q = result.quality) {
    out.align = *q;
  }
  if (truth == nullptr || ctx.target == nullptr || !result.T_camera_model) return;
  const Eigen::Isometry3d& T_camera_model = *result.T_camera_model;
  const Eigen::Isometry3d T_camera_model_true =
      truth->true_T_map_camera().inverse() * truth->true_T_map_model(ctx.target->id);
  out.target_pose_error =
      TargetPoseError{1000.0 * translation_distance_m(T_camera_model, T_camera_model_true),
                      rad_to_deg(rotation_angle_rad(T_camera_model, T_camera_model_true))};
}

void measure_project(const Context& ctx, const ProjectResult& result, GroundTruth* truth,
                     TargetMeasurements& out) {
  if (result.shown_s) {
    out.projected_s = *result.shown_s;
    out.beam_interruptions = result.beam_interruptions;
    out.blanked_s = result.blanked_s;
  }
  if (truth == nullptr || ctx.target == nullptr) return;
  const auto& before = result.pixels_before_align;
  const auto& after = result.pixels_after_align;
  BeforeAfter mm, px;
  const auto evaluate = [&](const std::optional<ProjectorQuad>& pixels,
                            std::optional<double> BeforeAfter::*field) {
    if (!pixels) return;
    if (const auto error = truth->evaluate_projection(ctx.target->id, *pixels)) {
      mm.*field = error->mean_mm();
      px.*field = error->mean_px();
    }
  };
  evaluate(before, &BeforeAfter::before_align);
  evaluate(after, &BeforeAfter::after_align);
  if (after) {
    if (const auto error = truth->evaluate_projection(ctx.target->id, *after)) {
      out.projection_error_area_mm = AreaError{error->area_error_mean_mm, error->area_error_max_mm};
      out.light_off_target_fraction = error->light_off_target_fraction;
    }
  }
  if (mm.before_align || mm.after_align) {
    out.projection_error_mm = mm;
    out.projection_error_px = px;
  }
  if (before && after && !ctx.target_dir.empty()) {
    const VerifyResult* verified = ctx.blackboard().find(keys::kVerify);
    truth->write_projection_views(ctx.target->id, *before, *after,
                                  verified ? verified->observed_colour_px : std::nullopt,
                                  ctx.target_dir);
  }
}

// The result under `key` when the state now ending wrote it.
template <typename T>
const T* written_since(const Blackboard& bb, const Key<T>& key, std::uint64_t since) {
  return bb.version(key) > since ? bb.find(key) : nullptr;
}

}  // namespace

void measure_step_results(const Context& ctx, std::uint64_t since_writes,
                          TargetMeasurements& measurements) {
  try {
    GroundTruth* truth = ctx.run->dry_run && ctx.run->drivers != nullptr
                             ? ctx.run->drivers->ground_truth()
                             : nullptr;
    const Blackboard& bb = ctx.blackboard();
    if (const auto* r = written_since(bb, keys::kNavigate, since_writes)) {
      measure_navigate(ctx, *r, truth, measurements);
    }
    if (const auto* r = written_since(bb, keys::kAlign, since_writes)) {
      measure_align(ctx, *r, truth, measurements);
    }
    if (const auto* r = written_since(bb, keys::kCalibrate, since_writes)) {
      measurements.calibration = *r;
    }
    if (const auto* r = written_since(bb, keys::kVerify, since_writes)) {
      measurements.observed_error_mm = r->observed_error_mm;
      measurements.observed_light_on_target = r->light_on_target_fraction;
    }
    if (const auto* r = written_since(bb, keys::kProject, since_writes)) {
      measure_project(ctx, *r, truth, measurements);
    }
  } catch (const std::exception& e) {
    if (ctx.run->log != nullptr) {
      ctx.run->log->warning("measuring the results of " + ctx.state_path + ": " + e.what());
    }
  }
}

}  // namespace projtour
