#pragma once
// The camera-projector transform from 3-D points (camera frame) and the projector pixels that
// lit them: the projector is a camera run backwards, so this is PnP with the projector's
// intrinsics and distortion -- RANSAC for the inliers, then Levenberg-Marquardt on the
// reprojection error in the projector.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/pinhole.hpp"

namespace projtour::light {

struct FitSettings {
  double ransac_threshold_px = 4.0;  // in the projector
  int ransac_iterations = 200;
  int min_inliers = 12;
};

struct ProjectorFit {
  std::optional<Eigen::Isometry3d> T_projector_camera;  // absent when no fit was possible
  int inliers = 0;
  double rms_px = 0.0;  // over the inliers, after refinement
  std::string problem;  // why there is no fit
};

// `guess` is the calibration believed now: RANSAC's model (EPnP on minimal samples) and the
// guess each get the correspondences within ransac_threshold_px, the larger set is refined by
// Levenberg-Marquardt (cv::solvePnPRefineLM) and renewed until it stops changing. Problems: the
// two lists differ in length, fewer points than min_inliers ("too few points: N (need M)"),
// fewer inliers ("too few inliers: N (need M)"). Deterministic: cv::theRNG() is held at a fixed
// state for the call and given back as it was.
ProjectorFit fit_projector_pose(const std::vector<Eigen::Vector3d>& points_camera,
                                const std::vector<Eigen::Vector2d>& projector_px,
                                const PinholeModel& projector,
                                const Eigen::Isometry3d& T_projector_camera_guess,
                                const FitSettings& settings = {});

}  // namespace projtour::light
