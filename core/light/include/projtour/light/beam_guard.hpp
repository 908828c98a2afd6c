#pragma once
// The beam guard: nobody stands in the projector's light. An image projector at eye level is a
// photobiological hazard (IEC 62471-5), so while the projector is lit every depth frame is
// searched for anything inside the lit part of the projector's frustum and nearer to the
// projector than the target: a person walking in, a hand, a child. The lit region is grown by
// a guard band measured in metres at each reading's depth (a fixed band of pixels would be a
// hair's breadth near the projector), so someone walking in is seen before the light reaches
// them.
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/model_cloud.hpp"
#include "projtour/contract/pinhole.hpp"

namespace projtour::light {

struct BeamGuardSettings {
  // Nearer than the target's nearest surface in the lit region by this counts as in the beam:
  // more than a depth camera's noise and a model's error, less than a hand in front of it.
  double margin_m = 0.10;
  // The lit region grown by this on every side, at the depth of what is looked at: two ticks
  // of someone walking in at 1.5 m/s.
  double guard_m = 0.15;
  // Readings it takes to be something (~2 cm^2 at 1 m with stride 2): fewer are noise and
  // flying pixels at the target's own edges.
  int min_points = 30;
  // Nearer than this to the projector is the robot itself.
  double min_range_m = 0.25;
  // Every stride_px-th pixel in each direction is looked at.
  int stride_px = 2;
  // No depth frame with readings for this long while lit and the light is not watched: it goes
  // dark. A dropped frame (no readings) is clear of everything and proves nothing. Someone at
  // 1.5 m/s crosses the 15 cm guard band in a tenth of this; a working camera never goes so long.
  double blind_s = 0.5;
};

struct BeamIntrusion {
  int points = 0;  // readings inside the grown region nearer than the target
  double nearest_m = std::numeric_limits<double>::infinity();  // along the projector's axis
  bool blocked = false;                                        // points >= min_points
};

class BeamGuard {
 public:
  explicit BeamGuard(const BeamGuardSettings& settings = {});
  const BeamGuardSettings& settings() const { return settings_; }

  // The light to guard: the projector in the camera frame, its intrinsics, the corners of the
  // lit region in projector pixels (a convex quadrilateral, any winding), and the target: its
  // model at T_camera_model, whose nearest point inside the region sets the depth limit.
  void arm(const Eigen::Isometry3d& T_projector_camera, const PinholeModel& projector,
           const std::array<Eigen::Vector2d, 4>& lit_px, const ModelCloud& model,
           const Eigen::Isometry3d& T_camera_model);
  bool armed() const { return armed_; }
  // The limit along the projector's axis: readings nearer than this are in the beam.
  double limit_m() const { return limit_m_; }

  // One depth frame (p_camera = p_depth + depth_to_color_m, as capture lifts it). `in_beam`,
  // when given, receives the indices of the pixels read in the beam.
  BeamIntrusion check(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                      std::vector<std::size_t>* in_beam = nullptr) const;
  // Of `pixels` (what check() found in the beam in an earlier frame from the same pose), how
  // many `frame` sees clear: a reading there, and out of the beam. A pixel without a reading is
  // not clear: what stood there may still.
  std::size_t seen_clear(const DepthFrame& frame, const Eigen::Vector3d& depth_to_color_m,
                         const std::vector<std::size_t>& pixels) const;

 private:
  // Within the lit region grown by guard_m at depth z_m (projector frame).
  bool in_region(const Eigen::Vector2d& px, double z_m) const;
  // The reading `mm` at pixel (u, v) is in the beam; its distance along the projector's axis
  // goes to `z_m`. Inlined: out of line, check() was a fifth slower (bench_live_loop).
  [[gnu::always_inline]] bool reads_in_beam(const PinholeModel& k, int u, int v, std::uint16_t mm,
                                            const Eigen::Matrix3d& R,
                                            const Eigen::Vector3d& t_projector_colour,
                                            double* z_m) const;

  BeamGuardSettings settings_;
  bool armed_ = false;
  Eigen::Isometry3d T_projector_camera_ = Eigen::Isometry3d::Identity();
  double fx_ = 1.0, fy_ = 1.0, cx_ = 0.0, cy_ = 0.0;
  // The region's edges as lines n . p >= c - guard (n unit, pointing inside).
  std::array<Eigen::Vector2d, 4> normal_;
  std::array<double, 4> offset_{};
  double limit_m_ = 0.0;
};

}  // namespace projtour::light
