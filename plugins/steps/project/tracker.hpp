#pragma once
// Live re-alignment for project's `track` option: each new depth frame is aligned from the last
// pose with a short ICP schedule that fits in a camera frame period, and the result is gated on
// quality before anyone re-warps with it.
#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/params.hpp"
#include "projtour/head/projection.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::project {

struct TrackSettings {
  bool enabled = false;
  double threshold_mm = 1.0;   // re-warp when a Model Point moves more (projector frame)
  double threshold_deg = 0.5;  // ... or the target turns more
  double min_inlier_fraction = 0.6;
  double crop_margin_m = 0.05;
};

// Throws std::invalid_argument naming the parameter (validation and construction share it).
TrackSettings read_track_settings(const Params& params);

// How far the Model Points move between two poses of the model (same frame): the largest
// point displacement (m) and the rotation between the poses (rad).
struct QuadMotion {
  double max_point_m = 0.0;
  double rotation_rad = 0.0;
};
QuadMotion model_points_motion(const head::Quad3d& model_points, const Eigen::Isometry3d& T_a_model,
                               const Eigen::Isometry3d& T_b_model);

// Per-visit figures for the log: how often tracking ran, kept up and re-warped.
struct TrackStats {
  int frames = 0;    // frames aligned
  int accepted = 0;  // passed the quality gate
  int rewarps = 0;
  std::vector<double> align_ms;
  std::vector<double> rewarp_ms;
  // Per camera frame while tracking: the grab, the beam watch and the whole tick's work.
  std::vector<double> capture_ms;
  std::vector<double> beam_ms;
  std::vector<double> frame_ms;
  // The tick's own work, the grab aside: a real camera's grab waits for the next frame and the
  // simulated one renders it, so only this says whether the loop fits in a frame.
  std::vector<double> work_ms;
  std::string summary() const;
};

class PoseTracker {
 public:
  explicit PoseTracker(const TrackSettings& settings);

  // Starts from `T_camera_model` on the model align fitted (its published AlignResult::model).
  void start(const std::shared_ptr<const ModelCloud>& model,
             const Eigen::Isometry3d& T_camera_model);

  // Aligns `frame` from the current pose; the pose moves only when the fit passes the gate.
  // nullopt for a frame without readings (a dropped frame).
  std::optional<perception::RegistrationResult> update(const DepthFrame& frame,
                                                       const Eigen::Vector3d& depth_to_color_m);
  bool accepted(const perception::RegistrationResult& r) const;

  const Eigen::Isometry3d& T_camera_model() const { return T_camera_model_; }
  TrackStats& stats() { return stats_; }

  // The schedule: the three finer levels of align's default, trimmed (fewer iterations, fewer
  // points at full resolution) to stay near a millisecond. Between frames the target moves little,
  // but a bump can shift it by centimetres at once, so the first stage still reaches 4 cm.
  static perception::IcpOptions icp_options();

 private:
  TrackSettings settings_;
  perception::IcpOptions options_;
  std::shared_ptr<const ModelCloud> cloud_;
  std::shared_ptr<const perception::IcpModel> model_;
  Eigen::Isometry3d T_camera_model_ = Eigen::Isometry3d::Identity();
  TrackStats stats_;
};

}  // namespace projtour::project
