#pragma once
// Frames for registration tests and benchmarks: the target on a floor, ray cast by the
// simulator's renderer with its Kinect-v1 noise model, seen from a robot standing in front.
#include <Eigen/Geometry>
#include <random>

#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/perception/model.hpp"
#include "projtour_sim/depth_renderer.hpp"
#include "projtour_sim/kinect_noise.hpp"

namespace projtour::test {

inline PinholeModel kinect_intrinsics() {
  PinholeModel k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 570.3;
  k.cx = 319.5;
  k.cy = 239.5;
  return k;
}

// The camera `distance_m` in front of the model (on its +x side), `height_m` above its origin,
// looking at the origin: optical z toward the model, x to the right, y down.
inline Eigen::Isometry3d T_camera_model_facing(double distance_m, double height_m = 0.0) {
  const Eigen::Vector3d eye(distance_m, 0.0, height_m);
  const Eigen::Vector3d z = (-eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T_model_camera = Eigen::Isometry3d::Identity();
  T_model_camera.linear().col(0) = x;
  T_model_camera.linear().col(1) = y;
  T_model_camera.linear().col(2) = z;
  T_model_camera.translation() = eye;
  return T_model_camera.inverse();
}

// `mesh` standing on a floor (at its lowest point), seen by the depth camera at
// T_depth_model, with (or without) Kinect noise.
inline DepthFrame render_on_floor(const perception::TriangleMesh& mesh,
                                  const Eigen::Isometry3d& T_depth_model, bool kinect_noise,
                                  unsigned seed) {
  sim::SceneBuilder builder;
  builder.add_mesh(mesh, Eigen::Isometry3d::Identity(), 1);
  float z_min = 0.0f;
  for (const auto& p : mesh.vertices) z_min = std::min(z_min, p.z());
  builder.set_floor(z_min, 0);
  const sim::Scene scene = builder.build();
  const PinholeModel k = kinect_intrinsics();
  const sim::DepthRenderer renderer(k);
  sim::IdealDepth ideal;
  renderer.render(scene, T_depth_model.inverse(), ideal);
  sim::KinectNoiseParams noise;
  noise.axial_noise = kinect_noise;
  noise.quantise = kinect_noise;
  std::mt19937_64 rng(seed);
  return sim::apply_kinect_noise(ideal, k, noise, rng);
}

// A pose error of exactly `trans_m` (camera frame) and `rot_rad` (about the model's origin),
// in random directions.
inline Eigen::Isometry3d perturb(const Eigen::Isometry3d& T_camera_model, double trans_m,
                                 double rot_rad, std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  Eigen::Isometry3d out = T_camera_model * Eigen::AngleAxisd(rot_rad, axis);
  out.translation() += trans_m * dir;
  return out;
}

}  // namespace projtour::test
