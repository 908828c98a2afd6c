#pragma once
// The verify step's measurements: where four projected dots land in the colour image, and how
// much of the content area's light lands on the target rather than in front of or behind it.
#include <Eigen/Geometry>
#include <array>
#include <opencv2/core.hpp>
#include <optional>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/model_cloud.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour/light/registered_depth.hpp"

namespace projtour::light {

// A projector frame with a white disc of `radius_px` at each of the four (distorted) pixels.
cv::Mat dots_frame(const PinholeModel& projector, const std::array<Eigen::Vector2d, 4>& pixels,
                   int radius_px);

// The brightness-weighted centroid of the light added between `dark` and `lit` (same exposure)
// within `search_px` of each expected colour pixel; nullopt for a dot not seen (too little
// added light there).
std::array<std::optional<Eigen::Vector2d>, 4> find_dots(
    const ColourFrame& dark, const ColourFrame& lit,
    const std::array<Eigen::Vector2d, 4>& expected_colour_px, double search_px,
    int min_added_level = 20);

// The model at T_camera_model seen by the colour camera: per colour pixel the depth of the
// nearest model point (splatted over 3x3 pixels), 0 where the model is not. Points whose normal
// faces away from the camera are left out when the model has normals.
std::vector<float> model_depth(const ModelCloud& model, const Eigen::Isometry3d& T_camera_model,
                               const PinholeModel& colour);

struct LightOnTarget {
  double on_target_fraction = 1.0;  // of the added light where depth was read, by brightness;
                                    // 0 when nothing was lit
  double in_front_fraction = 0.0;   // landing nearer than the target (an occluder)
  int lit_pixels = 0;
};

// Classifies each pixel that `lit` brightened over `dark` by more than `min_added_level`
// (grey levels): on the target where the registered depth agrees with `model_depth` within
// `tolerance_m`, in front where it is nearer (beside the model's silhouette: nearer than the
// model's nearest point), off the target otherwise (behind it, where the model is not, or
// without a depth reading). `depth` and `model_depth` are of the frames' size.
LightOnTarget light_on_target(const ColourFrame& dark, const ColourFrame& lit,
                              const RegisteredDepth& depth, const std::vector<float>& model_depth,
                              double tolerance_m = 0.03, int min_added_level = 20);

}  // namespace projtour::light
