#include "projtour_executor/measurements.hpp"

#include <array>

#include "projtour/blackboard_keys.hpp"
#include "projtour/geometry.hpp"
#include "projtour/ground_truth.hpp"

namespace projtour {

namespace {

Json pose_error_m(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  Json j = Json::object();
  j.set("trans_m", translation_distance_m(estimate, truth));
  j.set("rot_deg", rad_to_deg(rotation_angle_rad(estimate, truth)));
  return j;
}

void measure_navigate(const Context& ctx, GroundTruth* truth, Json& out) {
  if (truth == nullptr) return;
  const auto estimate = ctx.blackboard().get<PoseEstimate2D>(keys::kLocalization);
  if (!estimate) return;
  // Both on the floor plane: the estimate has no z, roll or pitch.
  const Eigen::Isometry3d T_map_base_true =
      isometry_from_pose2d(pose2d_from_isometry(truth->true_T_map_base()));
  out.set("localization_error",
          pose_error_m(isometry_from_pose2d(estimate->mean), T_map_base_true));
}

void measure_align(const Context& ctx, GroundTruth* truth, Json& out) {
  const Blackboard& bb = ctx.blackboard();
  if (const auto quality = bb.get<keys::AlignQuality>(keys::kAlignQuality)) {
    Json align = Json::object();
    align.set("method", quality->method);
    align.set("time_ms", quality->time_ms);
    align.set("iterations", quality->iterations);
    align.set("inlier_fraction", quality->inlier_fraction);
    align.set("rmse_mm", quality->rmse_mm);
    out.set("align", align);
  }
  if (truth == nullptr || ctx.target == nullptr) return;
  const auto T_camera_model = bb.get<Eigen::Isometry3d>(keys::kTCameraModel);
  if (!T_camera_model) return;
  const Eigen::Isometry3d T_camera_model_true =
      truth->true_T_map_camera().inverse() * truth->true_T_map_model(ctx.target->id);
  Json error = Json::object();
  error.set("trans_mm", 1000.0 * translation_distance_m(*T_camera_model, T_camera_model_true));
  error.set("rot_deg", rad_to_deg(rotation_angle_rad(*T_camera_model, T_camera_model_true)));
  out.set("target_pose_error", error);
}

void measure_project(const Context& ctx, GroundTruth* truth, Json& out) {
  const Blackboard& bb = ctx.blackboard();
  if (const auto shown_s = bb.get<double>(keys::kProjectedSeconds))
    out.set("projected_s", *shown_s);
  if (truth == nullptr || ctx.target == nullptr) return;
  using Pixels = std::array<Eigen::Vector2d, 4>;
  const auto before = bb.get<Pixels>(keys::kPixelsBeforeAlign);
  const auto after = bb.get<Pixels>(keys::kPixelsAfterAlign);
  Json mm = Json::object();
  Json px = Json::object();
  for (const auto& [name, pixels] : {std::pair{"before_align", before}, {"after_align", after}}) {
    if (!pixels) continue;
    if (const auto error = truth->evaluate_projection(ctx.target->id, *pixels)) {
      mm.set(name, error->mean_mm());
      px.set(name, error->mean_px());
    }
  }
  if (!mm.as_object().empty()) {
    out.set("projection_error_mm", mm);
    out.set("projection_error_px", px);
  }
  if (before && after && !ctx.target_dir.empty()) {
    truth->write_projection_views(ctx.target->id, *before, *after, ctx.target_dir);
  }
}

}  // namespace

void measure_on_exit(const std::string& kind, const Context& ctx, Json& measurements) {
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
