#pragma once
// The Kinect-v1 depth noise model, applied to an ideal rendered depth image.
//
// - Axial noise sigma(z) = 1.2 mm + 1.9 mm * (z - 0.4 m)^2 (Nguyen, Izadi, Lovell 2012). That
//   figure was measured on the camera's quantised output, so it is the TOTAL axial noise: the
//   Gaussian part drawn here is reduced by the quantisation variance step^2 / 12 so that
//   Gaussian + quantisation together have the published sigma.
// - Quantisation as the device does it: depth comes from disparity d = b f / z measured in
//   1/8 pixel steps (b = 7.5 cm, f = 580 px), so the depth step grows as z^2 / (8 b f)
//   (2.9 mm at 1 m, 26 mm at 3 m); the output is then in whole millimetres.
// - Missing pixels: beyond max_incidence_deg (grazing surfaces return no speckle), nearer than
//   min_depth_m and farther than max_depth_m.
#include <cstdint>
#include <random>

#include "projtour/depth_frame.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

struct KinectNoiseParams {
  bool axial_noise = true;  // false: ideal depth, still quantised and cut
  bool quantise = true;     // disparity quantisation (the 1 mm output step always applies)
  double min_depth_m = 0.4;
  double max_depth_m = 4.0;
  double max_incidence_deg = 75.0;
  double baseline_m = 0.075;
  double disparity_focal_px = 580.0;
  double disparity_step_px = 0.125;
};

// The published total axial sigma at depth z.
double kinect_axial_sigma_m(double z_m);
// Depth step of the disparity quantisation at depth z (0 when quantisation is off).
double kinect_quantisation_step_m(double z_m, const KinectNoiseParams& params);

// Noisy frame in millimetres (0 = no reading) with the given intrinsics; t_s and sequence are
// left for the caller. Draws from `rng` in pixel order, so a seeded engine gives the same frame.
DepthFrame apply_kinect_noise(const IdealDepth& ideal, const PinholeModel& intrinsics,
                              const KinectNoiseParams& params, std::mt19937_64& rng);

}  // namespace projtour::sim
