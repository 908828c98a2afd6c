#pragma once
// An analytic scene for the light tests and the closed-loop benchmark: rectangles and upright
// cylinders in the camera frame, seen by the Kinect's colour camera (with its lens distortion)
// and lit by the projector, plus the depth frame of the same scene from the depth camera with
// Kinect-v1-like noise. What the colour camera records is ambient light plus the projector frame
// sampled where each pixel's ray meets the scene (shadowed where the projector's ray meets
// something first), supersampled, blurred and noisy.
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/model_cloud.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour/light/gray_code.hpp"
#include "projtour/light/registered_depth.hpp"

namespace projtour::test {

struct LightRig {
  PinholeModel projector;  // 1280x800, the robot file's lens
  PinholeModel colour;     // Kinect v1 colour, 640x480, Burrus' distortion
  PinholeModel depth;      // Kinect v1 depth, 640x480, no distortion
  Eigen::Vector3d depth_to_color_m{0.05, 0.0, 0.0};  // p_camera = p_depth + depth_to_color_m
  Eigen::Isometry3d T_camera_projector = Eigen::Isometry3d::Identity();  // the truth
  Eigen::Isometry3d T_projector_camera() const { return T_camera_projector.inverse(); }
};

// The projector 0.14 m beside and above the camera, turned in by a few degrees so that its
// image centre lands near the camera's axis at 1.4 m.
LightRig default_rig();

struct Surface {
  enum class Kind { rectangle, cylinder, sphere };
  Kind kind = Kind::rectangle;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  // Rectangle: in-plane unit axes and half extents; its normal is u x v.
  Eigen::Vector3d u = Eigen::Vector3d::UnitX(), v = Eigen::Vector3d::UnitY();
  double half_u_m = 0.0, half_v_m = 0.0;
  // Cylinder (open, no caps): unit axis, radius, half height along the axis. Sphere: radius.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
  double radius_m = 0.0, half_height_m = 0.0;
  Eigen::Vector3f albedo_bgr{0.8f, 0.8f, 0.8f};
};

// A rectangle `width_m` x `height_m` centred at `centre` facing the camera (normal -z), turned by
// `yaw_rad` about the camera's y axis.
Surface facing_rectangle(const Eigen::Vector3d& centre, double width_m, double height_m,
                         double yaw_rad, const Eigen::Vector3f& albedo_bgr);
Surface upright_cylinder(const Eigen::Vector3d& centre, double radius_m, double height_m,
                         const Eigen::Vector3f& albedo_bgr);

struct Hit {
  double t = 0.0;
  int surface = -1;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, facing the ray's origin
};

struct Scene {
  std::vector<Surface> surfaces;
  // The nearest hit along origin + t * direction, t > 0.
  std::optional<Hit> intersect(const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& direction) const;
};

// Index 0 is the target in each of these; the last one is a wall behind everything.
Scene sign_scene();    // the 0.46 x 0.36 m sign at 1.4 m, turned by 10 degrees
Scene pillar_scene();  // a pillar of radius 0.16 m, its front at 1.3 m
Scene ball_scene();    // a ball of 15 cm at 1.0 m, the size of the Stanford bunny
// A 6 cm wide pole from top to bottom of the view at `z_m`, `x_m` across: the occluder.
void add_pole(Scene& scene, double x_m, double z_m);

struct ColourSettings {
  double ambient = 30.0;        // grey levels on albedo 1
  double projector_gain = 180;  // grey levels a white pixel adds on albedo 1, 1.4 m, head on
  double blur_sigma_px = 0.6;
  double noise_sigma = 1.5;  // grey levels, per channel
  int supersample = 3;       // per pixel and axis
};

class ColourRenderer {
 public:
  ColourRenderer(const LightRig& rig, const Scene& scene, const ColourSettings& settings = {});
  // The frame the colour camera records while the projector shows `projector_bgr` (BGR 8-bit,
  // projector size).
  ColourFrame render(const cv::Mat& projector_bgr, std::uint64_t seed) const;
  // Of pixel (u, v)'s samples: the fraction the projector reaches, the surface at its centre.
  double lit_fraction(int u, int v) const;
  int surface_at(int u, int v) const;

  // The truth along the colour ray through a (distorted) pixel.
  std::optional<Eigen::Vector3d> point_at(const Eigen::Vector2d& colour_px) const;
  std::optional<Eigen::Vector2d> projector_px_at(const Eigen::Vector2d& colour_px) const;
  // Where the projector's ray through `projector_px` lands in the colour image (nullopt when it
  // misses the scene or the camera does not see that point).
  std::optional<Eigen::Vector2d> colour_px_of(const Eigen::Vector2d& projector_px) const;

  const LightRig& rig() const { return rig_; }
  const Scene& scene() const { return scene_; }

 private:
  LightRig rig_;
  Scene scene_;
  ColourSettings settings_;
  int samples_ = 0;  // per pixel
  // Per sample, pixel-major: the projector pixel lighting it (-1: none), the light it receives
  // from a white projector pixel (gain, falloff and incidence), the surface it is on (-1: none).
  std::vector<std::int32_t> projector_index_;
  std::vector<float> light_;
  std::vector<std::int8_t> surface_;
  std::vector<std::int8_t> centre_surface_;
  std::vector<float> lit_fraction_;
};

// The colour frames of the whole sequence, frame i rendered with seed `seed + i`.
std::vector<ColourFrame> render_sequence(const ColourRenderer& renderer,
                                         const light::GrayCodeSequence& sequence,
                                         const cv::Mat& mask = cv::Mat(), std::uint64_t seed = 1);

// The decoded blocks lifted to 3-D (those that lift), beside the projector pixels that lit them:
// the input of the camera-projector fit.
struct Correspondences {
  std::vector<Eigen::Vector3d> points_camera;
  std::vector<Eigen::Vector2d> projector_px;
};
Correspondences lift_blocks(const light::DecodeResult& decoded,
                            const light::RegisteredDepth& depth);

// The scene's depth frame from the depth camera: millimetres, with Kinect-v1 noise when `noise`
// (Gaussian in disparity, sigma_z = 1.4e-3 z^2, then quantised to 1/8 disparity pixel).
DepthFrame render_depth(const LightRig& rig, const Scene& scene, std::uint64_t seed,
                        bool noise = true);

// The bounding box of `points_camera` in the colour image, `margin_px` larger.
cv::Rect colour_roi(const PinholeModel& colour, const std::vector<Eigen::Vector3d>& points_camera,
                    int margin_px);
// The projector pixels whose ray meets `surface` of the scene first (CV_8U, 255 = yes).
cv::Mat projector_mask(const LightRig& rig, const Scene& scene, int surface);
// The corners of a rectangle surface (camera frame).
std::vector<Eigen::Vector3d> rectangle_corners(const Surface& rectangle);
// A rectangle sampled every `spacing_m` as a model: the model frame is the rectangle's (origin
// at its centre, x = u, y = v, z = normal), returned with T_camera_model.
ModelCloud rectangle_model(const Surface& rectangle, double spacing_m,
                           Eigen::Isometry3d& T_camera_model);
// `T` moved by exactly `trans_m` and turned by exactly `rot_rad` about random directions.
Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, double trans_m, double rot_rad,
                          std::uint64_t seed);

}  // namespace projtour::test
