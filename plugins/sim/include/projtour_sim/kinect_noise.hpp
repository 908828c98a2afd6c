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
//
// Artefacts of the structured-light principle, each off by default (off, the frame is the same
// as without them, draw for draw):
//
// - Emitter shadows (`shadows`). Depth is triangulated between the IR camera and the speckle
//   emitter 7.5 cm beside it along the image x axis (Konolige & Mihelich, "Technical description
//   of Kinect calibration", ROS wiki 2011), so a surface the camera sees but the emitter's light
//   cannot reach carries no speckle and returns nothing: a band on the side of every foreground
//   object away from the emitter, fx b (1/z_near - 1/z_far) pixels wide. Seen from the front,
//   the Kinect v1 has the emitter, the colour camera and the IR camera left to right (Microsoft,
//   "Kinect for Windows Sensor Components and Specifications"; ROS rgbd_launch's kinect_frames puts
//   the depth camera 2.5 cm to the device's left of the colour camera), so the emitter is at +x of
//   the IR camera in its optical frame and the shadows fall on the left of objects in the image.
//   The test is exact in the rectified camera-emitter geometry: a point at pixel column u and
//   depth z appears in the emitter's view at u - side fx b / z on the same row; scanning a row
//   from the emitter's side, a pixel is in shadow when a pixel already scanned projects past it
//   there (the nearer surface lies on the emitter's line of sight). Rows are taken as epipolar
//   lines, so with lens distortion the test is as approximate as the rows are straight. It knows
//   only the surfaces in the image: an occluder thinner than its own shadow band (a wire)
//   shadows the whole band, where the real emitter would light part of it, and one just outside
//   the image casts nothing into it.
// - Flying pixels (`flying_pixels`). The disparity of a pixel is block-matched over a 9x9 (or
//   9x7) correlation window (Konolige & Mihelich); where the window straddles a depth edge the
//   match lands between the two surfaces' disparities, so pixels on either side of the edge
//   return depths in between. Modelled on the pixels with a 4-neighbour more than
//   flying_pixel_min_jump_m deeper or nearer: with probability flying_pixel_probability the
//   pixel's disparity becomes (1 - t) d_pixel + t d_neighbour, t uniform in (0, 1), with the
//   neighbour of the largest jump. Interpolating disparity, not depth, is what the matcher does;
//   the result then gets the axial noise and quantisation of its own depth. A neighbour in the
//   emitter's shadow has no speckle to match against and is not mixed in.
// - Spatially correlated noise (`correlated_noise`). The block matching shares most of its
//   window between neighbouring pixels, so the Kinect's noise comes in blobs about a window wide
//   rather than pixel by pixel. Modelled as a per-frame random field summed over a
//   correlation_window_px square (a box filter: neighbours correlate 1 - 1/window, 8/9 for 9 px,
//   nothing at a window or more), scaled at each pixel to correlated_noise_fraction * sigma(z).
//   The field sums uniform draws, not Gaussian ones: over 81 of them the sum is Gaussian to well
//   within what the camera shows (central limit), at a fraction of the cost. The total axial
//   sigma stays the published one: the white Gaussian part gives up the correlated variance
//   (sigma^2 (1 - fraction^2) - step^2 / 12, never below zero). The split is a choice, not a
//   measurement: the default 0.5 (a quarter of the variance correlated) is a plausible figure.
//
// Draw order (determinism): the correlated field first, H + w - 1 rows of W + w - 1 bytes, each
// row from ceil((W + w - 1) / 8) whole engine calls; then, pixel by pixel row-major, for each
// pixel with a reading, one 32-bit draw if it is a flying-pixel candidate and one Gaussian if
// the axial noise is on, two draws to an engine call. A shadowed pixel draws like any other, so
// turning shadows on only blanks pixels.
#include <cstdint>
#include <random>

#include "projtour/contract/depth_frame.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

struct KinectNoiseParams {
  bool axial_noise = true;  // false: ideal depth, still quantised and cut (no correlated part)
  bool quantise = true;     // disparity quantisation (the 1 mm output step always applies)
  double min_depth_m = 0.4;
  double max_depth_m = 4.0;
  double max_incidence_deg = 75.0;
  double baseline_m = 0.075;  // IR camera to emitter: disparity and shadows
  double disparity_focal_px = 580.0;
  double disparity_step_px = 0.125;

  bool shadows = false;
  // +1: the emitter at +x of the IR camera in its optical frame (the Kinect v1); -1: at -x.
  int emitter_side = +1;

  bool flying_pixels = false;
  double flying_pixel_probability = 0.5;  // per edge pixel, in [0, 1]
  // Depth step to a 4-neighbour that makes an edge, > 0: a steep but whole surface steps less
  // than 3 cm between pixels at 4 m (at the 75 deg incidence cut).
  double flying_pixel_min_jump_m = 0.05;

  bool correlated_noise = false;           // only with axial_noise
  double correlated_noise_fraction = 0.5;  // sigma of the correlated part / sigma(z), in [0, 1]
  // Side of the summing square. The Kinect's 9 px are at 640x480: scale it for other sizes.
  int correlation_window_px = 9;
};

// The published total axial sigma at depth z.
double kinect_axial_sigma_m(double z_m);
// Depth step of the disparity quantisation at depth z (0 when quantisation is off).
double kinect_quantisation_step_m(double z_m, const KinectNoiseParams& params);

// Noisy frame in millimetres (0 = no reading) with the given intrinsics; t_s and sequence are
// left for the caller. Draws only from `rng`, in the order given above, so a seeded engine gives
// the same frame. Throws std::invalid_argument on an emitter_side other than +-1, a probability
// or fraction outside [0, 1], a jump <= 0 or a window below 1 px (checked only for the artefacts
// that are on).
DepthFrame apply_kinect_noise(const IdealDepth& ideal, const PinholeModel& intrinsics,
                              const KinectNoiseParams& params, std::mt19937_64& rng);

}  // namespace projtour::sim
