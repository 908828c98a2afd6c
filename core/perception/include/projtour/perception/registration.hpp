#pragma once
// From a depth frame to the target's pose in the camera frame: organized clouds, frame
// averaging, cropping around a guess, and point-to-plane ICP with projective data association
// (as KinectFusion), Eigen only.
#include <Eigen/Geometry>
#include <cstddef>
#include <limits>
#include <vector>

#include "projtour/contract/depth_frame.hpp"
#include "projtour/perception/model.hpp"

namespace projtour::perception {

// Points in the camera frame laid out like (a window of) the depth image they came from.
// "Camera frame" is the depth optical frame moved by the depth-colour offset (the paper's eq. 2),
// i.e. p_camera = p_depth + depth_to_color_m, so poses come out in the frame the robot file
// calibrates. Pixels without a reading hold NaN.
struct OrganizedCloud {
  PinholeModel intrinsics;  // of the whole depth image
  Eigen::Vector3f depth_to_color_m = Eigen::Vector3f::Zero();
  // The window of the depth image this cloud covers: pixel (u0 + i, v0 + j) is
  // points[j * width + i].
  int u0 = 0;
  int v0 = 0;
  int width = 0;
  int height = 0;
  std::vector<Eigen::Vector3f> points;

  static bool valid(const Eigen::Vector3f& p) { return p.z() == p.z(); }
  const Eigen::Vector3f& at(int i, int j) const {
    return points[static_cast<std::size_t>(j) * width + i];
  }
  std::size_t valid_count() const;
};

// The whole frame as a cloud; readings outside [min_range_m, max_range_m] are dropped.
OrganizedCloud organized_cloud(const DepthFrame& frame,
                               const Eigen::Vector3d& depth_to_color_m = Eigen::Vector3d::Zero(),
                               double min_range_m = 0.0,
                               double max_range_m = std::numeric_limits<double>::infinity());

// Only the points within `radius_m` of `centre_camera` (camera frame), in the window of the
// image bounding the sphere's projection. Cheaper than organized_cloud + a filter,
// because pixels outside the window are never touched.
OrganizedCloud crop_sphere(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                           const Eigen::Vector3d& centre_camera, double radius_m);

// Pixelwise average of frames of one size: the mean of the readings within 3 % of the pixel's
// median, and no reading where fewer than half the frames had one (so dropouts neither pull the
// depth toward 0 nor invent points). Time stamp and sequence of the last frame. Throws
// std::invalid_argument on an empty list or frames of different sizes.
DepthFrame average_depth_frames(const std::vector<DepthFrame>& frames);

// One stage of the coarse-to-fine schedule.
struct IcpStage {
  int pyramid_level = 0;        // 0 = full resolution, each level halves width and height
  int max_model_points = 2000;  // uniform subset of the model used at this stage
  int search_radius_px = 0;  // association window: +- pixels around the projection, at this level
  double max_distance_m = 0.01;  // correspondences farther apart are rejected
  int iterations = 5;
  // Solve for translation only: far from the truth the rotation is poorly constrained and a
  // free rotation step can throw the model onto the support plane.
  bool translation_only = false;
};

struct IcpOptions {
  std::vector<IcpStage> stages = default_stages();
  double max_normal_angle_deg = 60.0;  // between model and scene normals
  // Tukey biweight scale as a multiple of the stage's max_distance_m (<= 0: plain least squares).
  double tukey_scale = 1.0;
  // A stage stops early when an update moves the model by less than this, times the level's
  // pixel size (2^level): a coarse level cannot resolve finer steps anyway.
  double min_update_m = 1e-4;
  double min_update_rad = 2e-4;
  // Quality is measured at full resolution: a visible model point is an inlier when its scene
  // point is within this distance.
  double inlier_distance_m = 0.006;
  // The coarse stage's safety net: when the result's inlier fraction stays under this, the
  // whole schedule runs again from hypotheses around the guess (shifted by hypothesis_offset_m
  // along each camera axis) and the best-fitting result wins. 0 disables it.
  double retry_below_inlier_fraction = 0.5;
  double hypothesis_offset_m = 0.06;

  static std::vector<IcpStage> default_stages();
};

struct RegistrationResult {
  Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
  bool converged = false;  // enough correspondences at every stage
  int iterations = 0;      // over all stages (and hypotheses)
  int hypotheses = 1;      // schedules run: 1, or more when the first fit was poor
  // Of the model points that face the camera, are not hidden behind the model's own parts and
  // land in the scene window: those with a scene point within inlier_distance_m.
  double inlier_fraction = 0.0;
  double rmse_mm = 0.0;  // point-to-plane, over the inliers
  std::size_t inliers = 0;
  // Valid full-resolution points the registration saw: the cloud's, or from a frame those of the
  // crop's parts it read (the tiles near where the model landed).
  std::size_t scene_points = 0;
  double time_ms = 0.0;
};

// The model prepared once for projective ICP: points in an order whose every prefix is a
// uniform subsample, so a stage takes its first N points.
class IcpModel {
 public:
  explicit IcpModel(const ModelCloud& cloud, unsigned seed = 1);
  const std::vector<Eigen::Vector3f>& points() const { return points_; }
  const std::vector<Eigen::Vector3f>& normals() const { return normals_; }
  float bounding_radius_m() const { return bounding_radius_m_; }
  // The same points and normals as six arrays of floats (point x, y, z, normal x, y, z), for
  // loops the compiler vectorizes.
  const float* column(int c) const {
    return columns_.data() + static_cast<std::size_t>(c) * size();
  }
  std::size_t size() const { return points_.size(); }

 private:
  std::vector<Eigen::Vector3f> points_;
  std::vector<Eigen::Vector3f> normals_;
  std::vector<float> columns_;
  float bounding_radius_m_ = 0.0f;
};

// Point-to-plane ICP of `model` against `scene` from `T_camera_model_guess`: each model point
// facing the camera under the current estimate is projected into the depth image (a level of
// its pyramid), matched with the scene point at that pixel or the nearest within the stage's
// window, rejected by distance and normal angle, weighted by Tukey's biweight, and each
// iteration solves the 6-DoF Gauss-Newton step with LDLT. time_ms covers the whole call.
RegistrationResult align_projective_icp(const IcpModel& model, const OrganizedCloud& scene,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        const IcpOptions& options = {});

// The same from the frame: crops to the model's bounding sphere plus `crop_margin_m` around the
// guess, then aligns; time_ms includes the crop. This is the call for re-aligning every frame
// (tracking): keep one IcpModel per target and pass the last pose as the guess.
RegistrationResult align_projective_icp(const IcpModel& model, const DepthFrame& frame,
                                        const Eigen::Vector3d& depth_to_color_m,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        double crop_margin_m, const IcpOptions& options = {});

// Quality of a pose, measured as align_projective_icp measures it at its end (full resolution,
// no window): inlier fraction and RMSE for `T_camera_model`.
RegistrationResult evaluate_alignment(const IcpModel& model, const OrganizedCloud& scene,
                                      const Eigen::Isometry3d& T_camera_model,
                                      const IcpOptions& options = {});

// How far the fit would move the given points (model frame) were it made without each part of
// the model in turn: the delete-one-block jackknife of the point-to-plane problem at the pose,
// blocks being cubes of `block_m` of the model. A model that fits the surface everywhere agrees
// with itself to the sensor's noise; a rough scan's parts disagree, each leaning the pose its own
// way, and the spread is what the pose is worth at those points. The largest over the points
// (one standard deviation, mm); 0 with fewer than four blocks of 20 matches.
struct PoseSpread {
  double model_point_mm = 0.0;
  int blocks = 0;
  std::size_t matches = 0;
};
PoseSpread pose_spread(const IcpModel& model, const OrganizedCloud& scene,
                       const Eigen::Isometry3d& T_camera_model,
                       const std::vector<Eigen::Vector3d>& points_model, double block_m = 0.04,
                       const IcpOptions& options = {});

}  // namespace projtour::perception
