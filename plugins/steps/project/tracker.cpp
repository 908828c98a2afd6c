#include "tracker.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "projtour/contract/geometry.hpp"
#include "step_names.hpp"

namespace projtour::project {

TrackSettings read_track_settings(const Params& p) {
  TrackSettings s;
  s.enabled = p.boolean(names::param::kTrack);
  s.threshold_mm = p.number(names::param::kTrackThresholdMm);
  s.threshold_deg = p.number(names::param::kTrackThresholdDeg);
  s.min_inlier_fraction = p.number(names::param::kTrackMinInlierFraction);
  s.crop_margin_m = p.number(names::param::kTrackCropMarginM);
  if (s.threshold_mm < 0.0) throw std::invalid_argument("track_threshold_mm: must be >= 0");
  if (s.threshold_deg < 0.0) throw std::invalid_argument("track_threshold_deg: must be >= 0");
  if (s.min_inlier_fraction < 0.0 || s.min_inlier_fraction > 1.0) {
    throw std::invalid_argument("track_min_inlier_fraction: must lie in [0, 1]");
  }
  if (s.crop_margin_m < 0.0) throw std::invalid_argument("track_crop_margin_m: must be >= 0");
  return s;
}

QuadMotion model_points_motion(const head::Quad3d& model_points, const Eigen::Isometry3d& T_a_model,
                               const Eigen::Isometry3d& T_b_model) {
  QuadMotion m;
  for (const Eigen::Vector3d& p : model_points) {
    m.max_point_m = std::max(m.max_point_m, (T_a_model * p - T_b_model * p).norm());
  }
  m.rotation_rad = rotation_angle_rad(T_a_model, T_b_model);
  return m;
}

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double maximum(const std::vector<double>& v) {
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}

}  // namespace

std::string TrackStats::summary() const {
  std::ostringstream s;
  s.precision(2);
  s << std::fixed << frames << " frames aligned, " << accepted << " passed the gate, " << rewarps
    << " re-warps; align median " << median(align_ms) << " ms (max " << maximum(align_ms)
    << "), re-warp median " << median(rewarp_ms) << " ms (max " << maximum(rewarp_ms) << ")";
  if (!frame_ms.empty()) {
    s << "; per frame median " << median(frame_ms) << " ms (max " << maximum(frame_ms)
      << "): capture " << median(capture_ms) << ", beam watch " << median(beam_ms)
      << " ms; the work besides capture median " << median(work_ms) << " ms (max "
      << maximum(work_ms) << ")";
  }
  return s.str();
}

perception::IcpOptions PoseTracker::icp_options() {
  perception::IcpOptions o;
  o.stages = {{2, 500, 1, 0.04, 4}, {1, 1000, 0, 0.02, 3}, {0, 3000, 0, 0.01, 3}};
  // A frame that fits badly is skipped, not searched around: the next one comes in 33 ms.
  o.retry_below_inlier_fraction = 0.0;
  return o;
}

PoseTracker::PoseTracker(const TrackSettings& settings)
    : settings_(settings), options_(icp_options()) {}

void PoseTracker::start(const std::shared_ptr<const ModelCloud>& model,
                        const Eigen::Isometry3d& T_camera_model) {
  if (!model) throw std::invalid_argument("PoseTracker::start without a model");
  // IcpModel lays the cloud out as align's does (same seed), so tracking follows the very points
  // align fitted; it is rebuilt only when align publishes another model.
  if (model != cloud_) {
    cloud_ = model;
    model_ = std::make_shared<const perception::IcpModel>(*model);
  }
  T_camera_model_ = T_camera_model;
  stats_ = {};
}

bool PoseTracker::accepted(const perception::RegistrationResult& r) const {
  return r.converged && r.inlier_fraction >= settings_.min_inlier_fraction;
}

std::optional<perception::RegistrationResult> PoseTracker::update(
    const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m) {
  if (!model_) throw std::logic_error("PoseTracker::update before start");
  if (frame.valid_count() == 0) return std::nullopt;
  perception::RegistrationResult r = perception::align_projective_icp(
      *model_, frame, depth_to_color_m, T_camera_model_, settings_.crop_margin_m, options_);
  ++stats_.frames;
  stats_.align_ms.push_back(r.time_ms);
  if (accepted(r)) {
    ++stats_.accepted;
    T_camera_model_ = r.T_camera_model;
  }
  return r;
}

}  // namespace projtour::project
