#pragma once
// The keys the shipped steps share, and the one typed result each step publishes. A kind's
// descriptor names the keys it reads and writes (plugin_author.hpp: reads(), writes()), so
// loading a machine checks that every read has a writer upstream on every path.
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/model_cloud.hpp"
#include "projtour/contract/robot.hpp"

namespace projtour {

// navigate: the path it planned last (replanning writes it again) and, once arrived, the
// estimate it stopped on.
struct NavigateResult {
  std::vector<Pose2D> planned_path;
  std::optional<PoseEstimate2D> arrived_at;
};

// capture: the frame, stamped with where the camera was when it was taken. Align uses these,
// not the joints and base at align time, which may have moved since.
struct CapturedFrame {
  DepthFrame frame;
  JointAngles joints;            // measured at capture
  PoseEstimate2D base_estimate;  // T_map_base estimate at capture
};

struct AlignQuality {
  std::string method;
  double time_ms = 0.0;
  int iterations = 0;
  double inlier_fraction = 0.0;
  double rmse_mm = 0.0;
};

// align: the guess it started from, the pose when the fit is good enough to use (absent when
// it is not), how good the fit was, the model it fitted and the joints the pose is valid at.
struct AlignResult {
  Eigen::Isometry3d T_camera_model_guess = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_camera_model;
  std::optional<AlignQuality> quality;  // absent when too few points were there to fit
  std::shared_ptr<const ModelCloud> model;
  JointAngles joints;
};

using ProjectorQuad = std::array<Eigen::Vector2d, 4>;

// project: how long the content was shown, and the projector pixels its corners went to from
// the guess alone and from the (last tracked) aligned pose, for the report's error figures.
struct ProjectResult {
  std::optional<double> shown_s;  // absent until the content went up
  std::optional<ProjectorQuad> pixels_before_align;
  std::optional<ProjectorQuad> pixels_after_align;
  std::optional<Eigen::Isometry3d> T_camera_model_tracked;  // when tracking moved the pose
  // The beam guard: how often someone in the beam blanked the projector, and for how long
  // (mission seconds; the dwell is extended by as much).
  int beam_interruptions = 0;
  double blanked_s = 0.0;
};

// calibrate: the camera-projector calibration the robot believes in now. Tour scope: measured on
// one target, it stands for the rest of the run until a later measurement replaces it.
struct ProjectorCalibration {
  MountSpec projector_mount;  // the estimated mount, as the robot file writes it
  Eigen::Isometry3d T_projector_camera = Eigen::Isometry3d::Identity();  // at `joints`
  JointAngles joints;
  std::string target;  // where it was measured
  double t_s = 0.0;    // mission time of the measurement
  int correspondences = 0;
  int inliers = 0;
  double rms_px = 0.0;  // reprojection error in the projector over the inliers
};

// calibrate: what this visit's structured-light sequence found, adopted or not.
struct CalibrateResult {
  int decoded_blocks = 0;  // projector blocks decoded on the target
  int inliers = 0;
  double rms_px = 0.0;
  double sequence_s = 0.0;  // mission time from the first pattern to the last frame
  double compute_ms = 0.0;  // decode and fit
  // The measured calibration against the one believed before, at the target's distance.
  double change_mm = 0.0;
  double change_deg = 0.0;
  bool adopted = false;
};

// verify: where the colour camera saw the content's corners land, against the Model Points at
// the aligned pose, and how much of the light fell on the target.
struct VerifyResult {
  std::optional<double> observed_error_mm;  // mean over the four corners; absent if not seen
  std::array<std::optional<double>, 4> corner_error_mm;
  std::optional<std::array<Eigen::Vector2d, 4>> observed_colour_px;
  std::array<Eigen::Vector2d, 4> expected_colour_px{};  // the Model Points, aligned pose
  double light_on_target_fraction = 0.0;
  double tolerance_mm = 0.0;
};

namespace keys {

// The localization service's estimate of T_map_base, every tick.
inline constexpr Key<PoseEstimate2D> kLocalization{"localization.estimate", KeyScope::tour,
                                                   "PoseEstimate2D"};
// True while the localization service considers itself converged.
inline constexpr Key<bool> kLocalizationConverged{"localization.converged", KeyScope::tour, "bool"};
// Widen the particle cloud by this many metres (relocalize sets it, the service takes it).
inline constexpr Key<double> kLocalizationWiden{"localization.widen_m", KeyScope::tour, "double"};
// The newest scan, republished by the localization service (which takes the laser's scans) so
// behaviours can look for obstacles.
inline constexpr Key<LaserScan> kLaserScan{"localization.scan", KeyScope::tour, "LaserScan"};

inline constexpr Key<NavigateResult> kNavigate{"navigate", KeyScope::visit, "NavigateResult"};
inline constexpr Key<CapturedFrame> kCapture{"capture", KeyScope::visit, "CapturedFrame"};
inline constexpr Key<AlignResult> kAlign{"align", KeyScope::visit, "AlignResult"};
inline constexpr Key<ProjectResult> kProject{"project", KeyScope::visit, "ProjectResult"};
inline constexpr Key<ProjectorCalibration> kCalibration{"calibration", KeyScope::tour,
                                                        "ProjectorCalibration"};
inline constexpr Key<CalibrateResult> kCalibrate{"calibrate", KeyScope::visit, "CalibrateResult"};
inline constexpr Key<VerifyResult> kVerify{"verify", KeyScope::visit, "VerifyResult"};

}  // namespace keys
}  // namespace projtour
