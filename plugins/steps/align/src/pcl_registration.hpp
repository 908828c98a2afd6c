#pragma once
// PCL's IterativeClosestPoint and GeneralizedIterativeClosestPoint behind a narrow interface:
// their templates cost ~18 s and 1 GB to compile, so they live in pcl_registration.cpp alone.
#include <Eigen/Geometry>
#include <memory>
#include <string>

#include "projtour/perception/registration.hpp"

namespace projtour::align {

enum class PclMethod { icp, gicp };
const char* to_string(PclMethod method);

struct PclOptions {
  int max_iterations = 50;
  // Wider lets them start farther off but drags the fit toward the floor in the crop.
  double max_correspondence_m = 0.05;
  double transformation_epsilon = 1e-8;
  // Model points handed to PCL: the same uniform prefix the projective ICP's last stage uses.
  std::size_t max_model_points = 2500;
};

class PclRegistration {
 public:
  PclRegistration(std::shared_ptr<const perception::IcpModel> model, PclMethod method,
                  const PclOptions& options = {});
  ~PclRegistration();
  PclRegistration(const PclRegistration&) = delete;
  PclRegistration& operator=(const PclRegistration&) = delete;

  // Registers the model (source) against the scene's valid points (target) from the guess.
  // Quality (inlier fraction, RMSE) is measured as for the projective ICP, so one quality gate
  // serves every method; time_ms covers the conversion, the search trees and the solve.
  perception::RegistrationResult align(const perception::OrganizedCloud& scene,
                                       const Eigen::Isometry3d& T_camera_model_guess,
                                       const perception::IcpOptions& quality_options = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace projtour::align
