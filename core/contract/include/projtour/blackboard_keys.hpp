#pragma once
// The blackboard keys the tour steps share, with the type stored under each. Keys under
// "target." are cleared by the executor when a visit to a new target starts.
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "projtour/depth_frame.hpp"
#include "projtour/geometry.hpp"

namespace projtour::keys {

// PoseEstimate2D: the localization service's estimate of T_map_base, every tick.
inline const std::string kLocalization = "localization.estimate";
// bool: true while the localization service considers itself converged.
inline const std::string kLocalizationConverged = "localization.converged";
// double: widen the particle cloud by this many metres (relocalize sets it, the service clears).
inline const std::string kLocalizationWiden = "localization.widen_m";

// LaserScan: the newest scan, republished by the localization service (which takes the laser's
// scans) so behaviours can look for obstacles.
inline const std::string kLaserScan = "localization.scan";

// std::vector<Pose2D>: the last path navigate planned (for tour.png).
inline const std::string kPlannedPath = "target.navigate.path";
// std::shared_ptr<const DepthFrame>: the frame capture took.
inline const std::string kDepthFrame = "target.capture.frame";
// Eigen::Isometry3d: align's initial guess and result.
inline const std::string kTCameraModelGuess = "target.align.T_camera_model_guess";
inline const std::string kTCameraModel = "target.align.T_camera_model";

struct AlignQuality {
  std::string method;
  double time_ms = 0.0;
  int iterations = 0;
  double inlier_fraction = 0.0;
  double rmse_mm = 0.0;
};
// AlignQuality of the last alignment.
inline const std::string kAlignQuality = "target.align.quality";

// std::array<Eigen::Vector2d, 4>: projector pixels chosen for the content corners, from the
// guess alone and from the aligned pose (the executor asks the ground truth about both).
inline const std::string kPixelsBeforeAlign = "target.project.pixels_before_align";
inline const std::string kPixelsAfterAlign = "target.project.pixels_after_align";
// double: seconds of content actually shown for this target.
inline const std::string kProjectedSeconds = "target.project.projected_s";

// long long: index of the target to visit next (set by next; the for_each reads it).
inline const std::string kNextTargetIndex = "tour.next_target_index";
// std::vector<std::string>: ids of the targets whose visit is over (projected or skipped), in
// the order they ended. The executor appends when a visit ends (and restores it from a
// checkpoint); next appends the target it leaves. next never picks a target listed here.
inline const std::string kDoneTargets = "tour.done_targets";

}  // namespace projtour::keys
