#pragma once
// The Kinect's colour camera, simulated: the scene under room light plus whatever the projector
// casts on it, seen through the camera's lens and sensor.
//
// Light transport (linear, photometric units):
// - Room light from the ceiling, as from a uniform overcast sky: a surface with unit normal n
//   gets room_lux * (1 + n_z) / 2 (the floor all of it, a wall or a target half).
// - The projector: a point source of luminous intensity I = lamp_lumens * fx * fy / (w * h)
//   (cd, for a full-white pixel: each of its w * h pixels sends lamp_lumens / (w * h) into its
//   1 / (fx * fy) steradian), so a surface at distance d and incidence angle a gets
//   I * cos(a) / d^2 times the linear value of the projector pixel its point falls in (lens
//   distortion included, bilinear between pixels). Pixel values are display-encoded (gamma 2.2),
//   and black is 1 / projector_contrast of white, not nothing. Light is stopped by whatever the
//   shadow ray from the projector's centre meets more than 1 cm before the point.
// - Every surface is Lambertian with a per-object albedo (B, G, R): radiance = albedo * E / pi.
// - What no ray hits (the open ceiling) has the radiance of a dull background.
// Camera (expose): a slight defocus blur, exposure (radiance * exposure_ms; full scale at
// kFullScaleNitMs), shot and read noise, then gamma 2.2 into 8 bits, clipped.
//
// The per-pixel geometry (what each pixel sees, where that point lies in the projector image,
// whether the projector reaches it and how strongly) depends only on the two poses and the scene,
// so it is kept: a structured-light sequence (many frames, robot still) costs a lookup per pixel.
//
// Usage:
//   ColourRenderer renderer(colour_intrinsics, projector_intrinsics);
//   renderer.set_albedo(object_id, {0.8f, 0.8f, 0.8f});
//   cv::Mat radiance;
//   renderer.render(scene, scene_version, T_world_camera, T_world_projector, &shown, radiance);
//   std::mt19937_64 rng(seed);
//   ColourFrame frame = renderer.expose(radiance, 20.0, &rng);
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <vector>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

struct ColourLight {
  double room_lux = 300.0;             // horizontal illuminance of the room light
  double lamp_lumens = 300.0;          // the projector's output for an all-white frame
  double projector_contrast = 1000.0;  // white / black of a lit projector
  double noise = 1.0;                  // scale of read and shot noise (0: noise-free)
  double blur_px = 0.6;                // defocus: Gaussian sigma in camera pixels (0: sharp)
};

// Linear reflectance per channel, in the image's B, G, R order.
using Albedo = std::array<float, 3>;

class ColourRenderer {
 public:
  // Radiance x exposure that saturates a pixel: a white target lit by the default lamp from
  // 1.4 m (about 180 cd/m^2) reaches half of it at the default 20 ms.
  static constexpr double kFullScaleNitMs = 7000.0;
  // Shot noise: the full-scale signal in photo-electrons; read noise as a fraction of full scale.
  static constexpr double kFullWellElectrons = 6000.0;
  static constexpr double kReadNoise = 0.003;

  ColourRenderer(const PinholeModel& camera, const PinholeModel& projector);
  const PinholeModel& camera() const { return depth_.intrinsics(); }
  const PinholeModel& projector() const { return projector_; }

  // Either drops the kept geometry.
  void set_light(const ColourLight& light);
  const ColourLight& light() const { return light_; }
  void set_albedo(int object_id, const Albedo& albedo);
  void set_default_albedo(const Albedo& albedo);
  void set_background(const Albedo& albedo);  // of what no ray hits, under vertical light

  // The radiance image (CV_32FC3, B G R, cd/m^2) of `scene` from the camera at T_world_camera
  // (optical frame) with the projector at T_world_projector (optical frame) showing `shown`
  // (8-bit BGR of the projector's size; null = the projector is off). `scene_version` changes
  // whenever the scene does: with it and both poses unchanged the kept geometry is used.
  void render(const Scene& scene, std::uint64_t scene_version,
              const Eigen::Isometry3d& T_world_camera, const Eigen::Isometry3d& T_world_projector,
              const cv::Mat* shown, cv::Mat& radiance);

  // The camera's frame of a radiance image: blur, exposure, noise from `rng` (none when null),
  // gamma, 8 bits. t_s and sequence are the caller's.
  ColourFrame expose(const cv::Mat& radiance, double exposure_ms, std::mt19937_64* rng) const;
  // What automatic exposure picks: the frame's mean at 18 % of full scale, within the limits.
  double auto_exposure_ms(const cv::Mat& radiance, double min_ms, double max_ms) const;

  // How often the per-pixel geometry was computed (the rest were lookups).
  std::size_t geometry_renders() const { return geometry_renders_; }

 private:
  // One camera pixel's light paths.
  struct PixelPath {
    Eigen::Vector3f ambient = Eigen::Vector3f::Zero();  // radiance under room light
    Eigen::Vector3f gain = Eigen::Vector3f::Zero();     // radiance per unit linear projector light
    std::int32_t tap = -1;       // the bilinear's top-left projector pixel (y * w + x); -1 = unlit
    float wx = 0.0f, wy = 0.0f;  // bilinear weights of the right and lower taps
  };
  struct Key {
    std::uint64_t scene_version = 0;
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_world_projector = Eigen::Isometry3d::Identity();
  };
  bool key_matches(std::uint64_t scene_version, const Eigen::Isometry3d& T_world_camera,
                   const Eigen::Isometry3d& T_world_projector) const;
  void compute_paths(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                     const Eigen::Isometry3d& T_world_projector);
  Albedo albedo(int object_id) const;

  DepthRenderer depth_;
  PinholeModel projector_;
  ColourLight light_;
  std::map<int, Albedo> albedo_;
  Albedo default_albedo_{0.5f, 0.5f, 0.5f};
  Albedo background_{0.3f, 0.3f, 0.3f};
  std::array<float, 256> projector_linear_{};  // display value -> linear light

  std::optional<Key> key_;
  std::vector<PixelPath> paths_;
  IdealDepth ideal_;
  std::size_t geometry_renders_ = 0;
};

}  // namespace projtour::sim
