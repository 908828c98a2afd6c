#include "target_view.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace projtour::closed_loop {

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s.precision(digits);
  s << std::fixed << v;
  return s.str();
}

std::string target_prefix(const Context& ctx) {
  return ctx.target != nullptr ? "target " + ctx.target->id + ": " : std::string();
}

TargetViewOrOutcome look_at_target(Context& ctx, double edge_margin_px) {
  const std::string who = target_prefix(ctx);
  const auto fail = [&](const std::string& why) {
    TargetViewOrOutcome out;
    out.outcome = Outcome{kOutcomeFailed, who + why};
    return out;
  };
  if (ctx.target == nullptr) return fail("runs only inside a visit");
  const DriverSet& d = ctx.drivers();
  if (!d.projector) return fail("no projector driver");
  if (!d.pan_tilt) return fail("no pan-tilt driver");
  if (!d.colour_camera) return fail("no colour camera driver (the closed loop needs one)");
  const AlignResult* aligned = ctx.blackboard().find(keys::kAlign);
  if (aligned == nullptr || !aligned->T_camera_model || !aligned->model) {
    return fail(std::string("no aligned pose and model on the blackboard (") + keys::kAlign.name +
                ")");
  }
  const CapturedFrame* capture = ctx.blackboard().find(keys::kCapture);
  if (capture == nullptr) {
    return fail(std::string("no captured depth frame on the blackboard (") + keys::kCapture.name +
                ")");
  }
  TargetView v;
  v.T_camera_model = *aligned->T_camera_model;
  v.model = aligned->model;
  v.capture = capture;
  v.joints = d.pan_tilt->measured();
  v.kinematics.emplace(
      head::believed_kinematics(ctx.robot(), ctx.blackboard().find(keys::kCalibration)));
  v.T_projector_camera = v.kinematics->T_projector_camera(v.joints);
  for (int i = 0; i < 4; ++i)
    v.model_points_camera[i] = v.T_camera_model * ctx.target->model_points[i];
  const PinholeModel& projector = ctx.robot().projector.intrinsics;
  v.quad = head::project_model_points(ctx.target->model_points,
                                      v.T_projector_camera * v.T_camera_model, projector);
  TargetViewOrOutcome out;
  if (edge_margin_px < 0.0) {
    out.view = std::move(v);
    return out;
  }
  const std::string problem = head::edge_problem(v.quad, projector, edge_margin_px);
  if (!problem.empty()) {
    out.outcome = Outcome{outcome::kOffScreen, who + problem};
    return out;
  }
  out.view = std::move(v);
  return out;
}

cv::Mat projector_mask(const TargetView& view, const PinholeModel& projector, int radius_px,
                       int margin_px) {
  cv::Mat mask(projector.height, projector.width, CV_8U, cv::Scalar(0));
  const Eigen::Isometry3d T_projector_model = view.T_projector_camera * view.T_camera_model;
  for (const Eigen::Vector3f& p : view.model->points) {
    const auto px = projector.project(T_projector_model * p.cast<double>());
    if (!px) continue;
    cv::circle(
        mask,
        cv::Point(static_cast<int>(std::lround(px->x())), static_cast<int>(std::lround(px->y()))),
        radius_px, cv::Scalar(255), cv::FILLED);
  }
  if (margin_px > 0) {
    const cv::Mat kernel = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, cv::Size(2 * margin_px + 1, 2 * margin_px + 1));
    cv::dilate(mask, mask, kernel);
  }
  return mask;
}

cv::Rect colour_roi(const TargetView& view, const PinholeModel& colour, int margin_px) {
  double lo_u = colour.width, lo_v = colour.height, hi_u = -1, hi_v = -1;
  for (const Eigen::Vector3f& p : view.model->points) {
    const auto px = colour.project(view.T_camera_model * p.cast<double>());
    if (!px) continue;
    lo_u = std::min(lo_u, px->x());
    lo_v = std::min(lo_v, px->y());
    hi_u = std::max(hi_u, px->x());
    hi_v = std::max(hi_v, px->y());
  }
  if (hi_u < lo_u) return cv::Rect();
  const cv::Rect grown(static_cast<int>(lo_u) - margin_px, static_cast<int>(lo_v) - margin_px,
                       static_cast<int>(hi_u - lo_u) + 2 * margin_px + 1,
                       static_cast<int>(hi_v - lo_v) + 2 * margin_px + 1);
  return grown & cv::Rect(0, 0, colour.width, colour.height);
}

}  // namespace projtour::closed_loop
