// The camera-projector transform by PnP in the projector: RANSAC for the inliers, then
// Levenberg-Marquardt on the reprojection error.
#include "projtour/light/projector_fit.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace projtour::light {

namespace {

struct PnpInput {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  cv::Matx33d K;
  std::vector<double> distortion;
};

struct Pose {
  cv::Vec3d rvec, tvec;
};

Pose pose_from(const Eigen::Isometry3d& T) {
  cv::Matx33d R;
  cv::eigen2cv(Eigen::Matrix3d(T.linear()), R);
  Pose p;
  cv::Rodrigues(R, p.rvec);
  p.tvec = cv::Vec3d(T.translation().x(), T.translation().y(), T.translation().z());
  return p;
}

Eigen::Isometry3d isometry_from(const Pose& p) {
  cv::Matx33d R;
  cv::Rodrigues(p.rvec, R);
  Eigen::Matrix3d R_eigen;
  cv::cv2eigen(R, R_eigen);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_eigen;
  T.translation() = Eigen::Vector3d(p.tvec[0], p.tvec[1], p.tvec[2]);
  return T;
}

// Squared reprojection errors (projector pixels) of every point under `pose`.
std::vector<double> squared_errors(const PnpInput& in, const Pose& pose) {
  std::vector<cv::Point2d> projected;
  cv::projectPoints(in.object, pose.rvec, pose.tvec, in.K, in.distortion, projected);
  std::vector<double> e(projected.size());
  for (std::size_t i = 0; i < projected.size(); ++i) {
    const cv::Point2d d = projected[i] - in.image[i];
    e[i] = d.dot(d);
  }
  return e;
}

std::vector<int> inliers_of(const std::vector<double>& squared, double threshold_px) {
  std::vector<int> inliers;
  const double limit = threshold_px * threshold_px;
  for (std::size_t i = 0; i < squared.size(); ++i) {
    if (squared[i] <= limit) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

// OpenCV's RANSAC draws from an RNG of its own, but the kernels may use cv::theRNG; a fixed
// state for the call (and the caller's restored after) keeps the fit independent of history.
class FixedRng {
 public:
  FixedRng() : saved_(cv::theRNG().state) { cv::theRNG().state = 0x9e3779b97f4a7c15ULL; }
  ~FixedRng() { cv::theRNG().state = saved_; }
  FixedRng(const FixedRng&) = delete;
  FixedRng& operator=(const FixedRng&) = delete;

 private:
  std::uint64_t saved_;
};

std::string count_problem(const char* what, std::size_t have, int need) {
  return std::string(what) + ": " + std::to_string(have) + " (need " + std::to_string(need) + ")";
}

}  // namespace

ProjectorFit fit_projector_pose(const std::vector<Eigen::Vector3d>& points_camera,
                                const std::vector<Eigen::Vector2d>& projector_px,
                                const PinholeModel& projector,
                                const Eigen::Isometry3d& T_projector_camera_guess,
                                const FitSettings& settings) {
  ProjectorFit fit;
  if (points_camera.size() != projector_px.size()) {
    fit.problem = "fit: " + std::to_string(points_camera.size()) + " points for " +
                  std::to_string(projector_px.size()) + " projector pixels";
    return fit;
  }
  // EPnP's minimal sample is 5 points; the refinement needs more than the 6 unknowns.
  const int min_inliers = std::max(settings.min_inliers, 6);
  if (static_cast<int>(points_camera.size()) < min_inliers) {
    fit.problem = count_problem("too few points", points_camera.size(), min_inliers);
    return fit;
  }
  if (projector.fx <= 0.0 || projector.fy <= 0.0) {
    fit.problem = "fit: projector intrinsics without a focal length";
    return fit;
  }

  PnpInput in;
  in.K = cv::Matx33d(projector.fx, 0, projector.cx, 0, projector.fy, projector.cy, 0, 0, 1);
  in.distortion.assign(projector.distortion.begin(), projector.distortion.end());
  in.object.reserve(points_camera.size());
  in.image.reserve(points_camera.size());
  for (std::size_t i = 0; i < points_camera.size(); ++i) {
    in.object.emplace_back(points_camera[i].x(), points_camera[i].y(), points_camera[i].z());
    in.image.emplace_back(projector_px[i].x(), projector_px[i].y());
  }

  const Pose guess = pose_from(T_projector_camera_guess);
  Pose pose = guess;
  std::vector<int> inliers;
  try {
    const FixedRng fixed_rng;
    cv::Mat rvec = cv::Mat(guess.rvec).clone(), tvec = cv::Mat(guess.tvec).clone();
    std::vector<int> ransac_inliers;
    const bool found = cv::solvePnPRansac(
        in.object, in.image, in.K, in.distortion, rvec, tvec, /*useExtrinsicGuess=*/true,
        std::max(settings.ransac_iterations, 1), static_cast<float>(settings.ransac_threshold_px),
        0.999, ransac_inliers, cv::SOLVEPNP_EPNP);
    if (found) pose = Pose{cv::Vec3d(rvec.reshape(1, 3)), cv::Vec3d(tvec.reshape(1, 3))};
    // The belief competes with RANSAC's model: whichever explains more correspondences starts
    // the refinement (a model from a noisy 5-point sample can explain fewer than a belief a few
    // millimetres off).
    const std::vector<int> guess_inliers =
        inliers_of(squared_errors(in, guess), settings.ransac_threshold_px);
    if (found && ransac_inliers.size() >= guess_inliers.size()) {
      inliers = ransac_inliers;
    } else {
      pose = guess;
      inliers = guess_inliers;
    }

    // LM on the inliers; the refined pose may bring back points a rough sample left out, so
    // the set is renewed until it stops changing (a few rounds at most).
    for (int round = 0; round < 4; ++round) {
      if (static_cast<int>(inliers.size()) < min_inliers) break;
      std::vector<cv::Point3d> object;
      std::vector<cv::Point2d> image;
      object.reserve(inliers.size());
      image.reserve(inliers.size());
      for (int i : inliers) {
        object.push_back(in.object[static_cast<std::size_t>(i)]);
        image.push_back(in.image[static_cast<std::size_t>(i)]);
      }
      cv::Mat r = cv::Mat(pose.rvec).clone(), t = cv::Mat(pose.tvec).clone();
      cv::solvePnPRefineLM(
          object, image, in.K, in.distortion, r, t,
          cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-10));
      pose = Pose{cv::Vec3d(r.reshape(1, 3)), cv::Vec3d(t.reshape(1, 3))};
      std::vector<int> renewed = inliers_of(squared_errors(in, pose), settings.ransac_threshold_px);
      if (renewed == inliers) break;
      inliers = std::move(renewed);
    }
  } catch (const cv::Exception& e) {
    fit.problem = std::string("fit: OpenCV: ") + e.what();
    return fit;
  }

  fit.inliers = static_cast<int>(inliers.size());
  if (fit.inliers < min_inliers) {
    fit.problem = count_problem("too few inliers", inliers.size(), min_inliers);
    return fit;
  }
  const std::vector<double> squared = squared_errors(in, pose);
  double sum = 0.0;
  for (int i : inliers) sum += squared[static_cast<std::size_t>(i)];
  fit.rms_px = std::sqrt(sum / fit.inliers);
  fit.T_projector_camera = isometry_from(pose);
  return fit;
}

}  // namespace projtour::light
