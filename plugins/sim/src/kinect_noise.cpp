// The Kinect-v1 noise model (see kinect_noise.hpp for the sources and choices).
#include "projtour_sim/kinect_noise.hpp"

#include <cmath>

#include "projtour/geometry.hpp"

namespace projtour::sim {

double kinect_axial_sigma_m(double z_m) {
  const double dz = z_m - 0.4;
  return 0.0012 + 0.0019 * dz * dz;
}

double kinect_quantisation_step_m(double z_m, const KinectNoiseParams& params) {
  if (!params.quantise) return 0.0;
  return z_m * z_m * params.disparity_step_px / (params.baseline_m * params.disparity_focal_px);
}

DepthFrame apply_kinect_noise(const IdealDepth& ideal, const PinholeModel& intrinsics,
                              const KinectNoiseParams& params, std::mt19937_64& rng) {
  DepthFrame frame;
  frame.intrinsics = intrinsics;
  frame.width = ideal.width;
  frame.height = ideal.height;
  frame.depth_mm.assign(ideal.depth_m.size(), 0);
  const float min_cos = static_cast<float>(std::cos(deg_to_rad(params.max_incidence_deg)));
  const double bf_px = params.baseline_m * params.disparity_focal_px;
  const double steps_per_px = 1.0 / params.disparity_step_px;
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  for (std::size_t i = 0; i < ideal.depth_m.size(); ++i) {
    const double z = ideal.depth_m[i];
    if (z < params.min_depth_m || z > params.max_depth_m || ideal.cos_incidence[i] < min_cos) {
      continue;
    }
    double z_noisy = z;
    if (params.axial_noise) {
      const double sigma = kinect_axial_sigma_m(z);
      const double step = kinect_quantisation_step_m(z, params);
      const double gaussian_var = std::max(sigma * sigma - step * step / 12.0, 0.0);
      z_noisy += std::sqrt(gaussian_var) * unit_normal(rng);
    }
    if (params.quantise && z_noisy > 0.0) {
      const double disparity_steps = std::round(bf_px / z_noisy * steps_per_px);
      if (disparity_steps <= 0.0) continue;
      z_noisy = bf_px / (disparity_steps / steps_per_px);
    }
    if (z_noisy < params.min_depth_m || z_noisy > params.max_depth_m) continue;
    frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround(z_noisy * 1000.0));
  }
  return frame;
}

}  // namespace projtour::sim
