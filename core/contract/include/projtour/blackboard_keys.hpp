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

#include "projtour/blackboard.hpp"
#include "projtour/depth_frame.hpp"
#include "projtour/drivers.hpp"
#include "projtour/geometry.hpp"
#include "projtour/model_cloud.hpp"

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

}  // namespace keys
}  // namespace projtour
