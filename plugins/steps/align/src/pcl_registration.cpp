// The only translation unit that instantiates PCL's registration templates.
#include "pcl_registration.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>

#include <chrono>

namespace projtour::align {

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// PCL keeps the iteration count protected; the report wants it.
template <typename Base>
class Counting : public Base {
 public:
  int iterations() const { return this->nr_iterations_; }
};
using Icp = Counting<pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, float>>;
using Gicp = Counting<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>;

}  // namespace

const char* to_string(PclMethod method) {
  return method == PclMethod::icp ? "pcl_icp" : "pcl_gicp";
}

struct PclRegistration::Impl {
  std::shared_ptr<const perception::IcpModel> model;
  PclMethod method;
  PclOptions options;
};

PclRegistration::PclRegistration(std::shared_ptr<const perception::IcpModel> model,
                                 PclMethod method, const PclOptions& options)
    : impl_(new Impl{std::move(model), method, options}) {}

PclRegistration::~PclRegistration() = default;

namespace {

template <typename Registration>
void configure(Registration& reg, const PclOptions& options) {
  reg.setMaximumIterations(options.max_iterations);
  reg.setMaxCorrespondenceDistance(options.max_correspondence_m);
  reg.setTransformationEpsilon(options.transformation_epsilon);
  reg.setEuclideanFitnessEpsilon(1e-10);
}

}  // namespace

perception::RegistrationResult PclRegistration::align(
    const perception::OrganizedCloud& scene, const Eigen::Isometry3d& T_camera_model_guess,
    const perception::IcpOptions& quality_options) const {
  const auto started = std::chrono::steady_clock::now();
  Cloud::Ptr target(new Cloud);
  target->reserve(scene.points.size());
  for (const Eigen::Vector3f& p : scene.points) {
    if (perception::OrganizedCloud::valid(p)) target->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  perception::RegistrationResult result;
  result.T_camera_model = T_camera_model_guess;
  if (target->size() < 10) {
    result.scene_points = target->size();
    return result;
  }
  // The model side facing the camera at the guess, as the projective ICP uses: closest-point
  // ICP would otherwise drag the hidden back side onto the visible front and the floor.
  Cloud::Ptr source(new Cloud);
  const auto& points = impl_->model->points();
  const auto& normals = impl_->model->normals();
  const Eigen::Matrix3f R = T_camera_model_guess.linear().cast<float>();
  const Eigen::Vector3f t = T_camera_model_guess.translation().cast<float>();
  for (std::size_t i = 0; i < std::min(points.size(), impl_->options.max_model_points); ++i) {
    if ((R * normals[i]).dot(R * points[i] + t - scene.depth_to_color_m) >= 0.0f) continue;
    source->push_back(pcl::PointXYZ(points[i].x(), points[i].y(), points[i].z()));
  }
  const Eigen::Matrix4f guess = T_camera_model_guess.matrix().cast<float>();
  Cloud aligned;
  Eigen::Matrix4f final_transform;
  bool converged = false;
  int iterations = 0;
  if (impl_->method == PclMethod::icp) {
    Icp icp;
    configure(icp, impl_->options);
    icp.setInputSource(source);
    icp.setInputTarget(target);
    icp.align(aligned, guess);
    converged = icp.hasConverged();
    final_transform = icp.getFinalTransformation();
    iterations = icp.iterations();
  } else {
    Gicp gicp;
    configure(gicp, impl_->options);
    gicp.setInputSource(source);
    gicp.setInputTarget(target);
    gicp.align(aligned, guess);
    converged = gicp.hasConverged();
    final_transform = gicp.getFinalTransformation();
    iterations = gicp.iterations();
  }
  Eigen::Isometry3d T(final_transform.cast<double>());
  T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  result = perception::evaluate_alignment(*impl_->model, scene, T, quality_options);
  result.converged = converged;
  result.iterations = iterations;
  result.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace projtour::align
