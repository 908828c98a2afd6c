#pragma once
// Inside the sim plugin: the referee of the building (BuildingTruth). Every sub-step, the
// robot's clearance to every unmapped object and person; every tick, whether the lit projector's
// light falls on anyone. The projection's own figures are projection_truth.hpp's.
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "bodies/building.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

// The referee's clearance: the robot's radius plus this to any object or person.
constexpr double kClearanceMarginM = 0.10;

class BuildingReferee {
 public:
  BuildingReferee();
  // The robot's centre at `xy`: its clearance to every object and person.
  void clearance(const Eigen::Vector2d& xy, const std::vector<Footprint>& footprints,
                 const std::vector<PersonShape>* people, double robot_radius_m);
  // dt_s of the projector showing `shown` (8-bit BGR) from T_map_projector: does its light fall
  // on anyone's head or body (a ray through the scene meets them first)?
  void light(double dt_s, const cv::Mat& shown, const Eigen::Isometry3d& T_map_projector,
             const PinholeModel& projector, const Scene& scene,
             const std::vector<PersonShape>& people);
  // The figures so far; the counts are the caller's.
  const BuildingTruth& figures() const { return figures_; }

 private:
  BuildingTruth figures_;
  bool in_violation_ = false;
};

}  // namespace projtour::sim
