#pragma once
// A target's model as registration uses it. In the contract because align publishes the model it
// fitted, so project's tracking follows the very same points without loading them again.
#include <Eigen/Core>
#include <vector>

namespace projtour {

// Points with unit normals, model frame, metres.
struct ModelCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
  float bounding_radius_m = 0.0f;  // about the model origin
};

}  // namespace projtour
