#pragma once
// The depth frame registered into the colour camera (the paper's eq. 2): each depth reading
// lifted into the depth optical frame, moved by depth_to_color_m into the colour optical frame
// (the robot's camera frame), and z-buffered into the colour image. Colour pixels are lifted to
// 3-D against it by a local plane fit, which averages the Kinect's noise.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/pinhole.hpp"

namespace projtour::light {

struct RegisteredDepth {
  PinholeModel colour;
  std::vector<float> z_m;  // colour width * height, along the colour optical axis; 0 = none
  // The reading each pixel holds, as the 3-D point it was (camera frame; NaN where z_m is 0):
  // lift fits these rather than pixel centres at z_m, which would add the rounding to a pixel
  // and need the colour lens undone per reading.
  std::vector<Eigen::Vector3f> points_camera;
  float at(int u, int v) const { return z_m[static_cast<std::size_t>(v) * colour.width + u]; }
};

// Each reading z-buffered into the colour pixel it projects to (colour lens applied). Then a
// pixel that no reading landed on takes the nearest of the readings on its 8 neighbours, as a
// 3x3 splat behind the exact ones would: the colour lens stretches the image corners by up to
// ~1.4x against the depth image, which leaves 1-2 pixel holes. A reading far behind at least 5
// of its neighbours gives way to the nearest of them: it is background the depth camera saw
// through such a hole in a surface that the colour camera sees in front of it.

RegisteredDepth register_depth(const DepthFrame& depth, const Eigen::Vector3d& depth_to_color_m,
                               const PinholeModel& colour);

// The 3-D point (camera frame) where the colour ray through `colour_px` (distorted pixel) meets
// the plane fitted to the registered depth within `window_px` of it. Readings farther than
// `max_spread_m` from the depth next to the pixel are another surface and left out. nullopt with
// too few readings there (or none next to the pixel: what it sees is unknown), a fit whose
// spread is larger than `max_spread_m` (an edge, two surfaces), a plane that would have to be
// extrapolated to the ray (its readings all to one side), or one seen at more than
// `max_view_angle_deg` from head-on, where the Kinect's depth and a block's footprint both
// degrade.
std::optional<Eigen::Vector3d> lift(const RegisteredDepth& depth, const Eigen::Vector2d& colour_px,
                                    int window_px = 4, double max_spread_m = 0.02,
                                    double max_view_angle_deg = 60.0);

}  // namespace projtour::light
