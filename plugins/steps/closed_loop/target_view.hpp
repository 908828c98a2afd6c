#pragma once
// The target as calibrate and verify see it: the aligned pose, the head's angles now, the
// calibration believed now, and from them where the Model Points and the model fall in the
// projector and in the colour camera.
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/head/projection.hpp"
#include "step_names.hpp"

namespace projtour::closed_loop {

struct TargetView {
  Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
  std::shared_ptr<const ModelCloud> model;
  JointAngles joints;  // measured now; the head holds still through the step
  std::optional<head::HeadKinematics> kinematics;  // believed: robot file + calibration
  Eigen::Isometry3d T_projector_camera = Eigen::Isometry3d::Identity();
  head::ProjectedQuad quad;  // Model Points in the projector
  std::array<Eigen::Vector3d, 4> model_points_camera;
  const CapturedFrame* capture = nullptr;  // the depth frame align fitted
};

// Everything calibrate and verify need before they light anything, or the outcome that stops
// them: "failed" (a missing driver or result) or "off_screen" (a Model Point outside the
// projector image or within edge_margin_px of its border: the head must be re-aimed).
struct TargetViewOrOutcome {
  std::optional<TargetView> view;
  std::optional<Outcome> outcome;
};
// A negative edge_margin_px skips the on-screen check (calibrate lights what of the target the
// projector reaches; the Model Points need be on screen only for what is shown on them).
TargetViewOrOutcome look_at_target(Context& ctx, double edge_margin_px);

// Projector pixels that light the model (its points splatted with radius_px, then grown by
// margin_px): the structured light stays on the target area.
cv::Mat projector_mask(const TargetView& view, const PinholeModel& projector, int radius_px,
                       int margin_px);

// The colour pixels the model covers, grown by margin_px and clipped to the image.
cv::Rect colour_roi(const TargetView& view, const PinholeModel& colour, int margin_px);

std::string target_prefix(const Context& ctx);
// `v` with `digits` decimals, for the steps' messages.
std::string fixed(double v, int digits);

}  // namespace projtour::closed_loop
