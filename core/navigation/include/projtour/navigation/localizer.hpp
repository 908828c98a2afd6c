#pragma once
// Monte Carlo localization on an occupancy grid (MRPT's CMonteCarloLocalization2D driven by a
// CParticleFilter): odometry increments as the motion model, the laser's likelihood field on the
// map as the measurement model. The localization service and `projtour localize` share it.
//
// A real building is not its map: walls drawn thick, people and furniture the map never saw.
// Three things keep the filter honest there (each measured in docs/localization.md):
// - the likelihood field is built from the walls' boundary, not from every occupied cell, so a
//   scan endpoint that falls inside a thick wall is not forgiven (that forgiveness lets the
//   estimate slide along corridors);
// - once converged, a run of readings well short of the range the map predicts from the
//   estimate, no wider than a person or a piece of furniture, is something the map does not hold
//   and is left out of the update;
// - when the scans suddenly stop fitting (a drop of the recent scan likelihood against its long
//   average, as in augmented MCL), a few particles are drawn afresh around the estimate at a
//   low weight, so a cloud that collapsed onto the wrong place can recover.
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "projtour/contract/drivers.hpp"
#include "projtour/contract/geometry.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}
namespace mrpt::obs {
class CObservation2DRangeScan;
}

namespace projtour::navigation {

struct LocalizerOptions {
  int particles = 1000;
  // Initial cloud around the pose guess: uniform within +-spread.
  double init_spread_m = 0.3;
  double init_spread_deg = 10.0;
  // Odometry error model (MRPT's Gaussian model): standard deviation per unit travelled/turned,
  // plus a floor so a robot at rest keeps some diversity.
  double odom_trans_noise_frac = 0.08;
  double odom_rot_noise_frac = 0.08;
  double odom_min_std_m = 0.01;
  double odom_min_std_deg = 0.5;
  // Likelihood field: the range's error model and how many rays are skipped per ray used.
  double lf_sigma_m = 0.10;
  double lf_max_corr_m = 0.50;
  int lf_decimation = 6;
  // The field's walls: the boundary of free space (the default), or every occupied cell as MRPT
  // builds it from the map (kept to compare against).
  enum class Field { boundary, occupied };
  Field lf_field = Field::boundary;
  // Once converged, rays shorter than the map's predicted range by more than this are left out
  // (0: keep every ray).
  double short_reading_m = 0.3;
  // Depletion guard: the largest share of particles redrawn in one update (0: off), around the
  // estimate within +-inject_spread_m and +-inject_spread_deg.
  double inject_max_frac = 0.1;
  double inject_spread_m = 1.0;
  double inject_spread_deg = 20.0;
  // Systematic resampling when the effective sample size falls below this fraction.
  double resample_beta = 0.5;
  // Converged while the cloud's standard deviations are below these and the scans still fit
  // the map: a kidnapped robot keeps a tight cloud in the wrong place, but its scans stop
  // landing on walls.
  double converged_std_m = 0.15;
  double converged_std_deg = 5.0;
  double converged_min_fit = 0.5;
};

class Localizer {
 public:
  // Copies the map (its likelihood cache is per copy). Seeds MRPT's random generator, which the
  // particle filter draws from.
  Localizer(const mrpt::maps::COccupancyGridMap2D& map, const LocalizerOptions& options,
            std::uint64_t seed);
  ~Localizer();
  Localizer(const Localizer&) = delete;
  Localizer& operator=(const Localizer&) = delete;

  const LocalizerOptions& options() const { return options_; }

  // Particles uniformly around `guess` within the options' initial spread.
  void reset(const Pose2D& guess);
  // Spreads every particle by up to +-spread_m and +-spread_rad (kidnapping, recovery).
  void widen(double spread_m, double spread_rad);

  // One prediction (odometry increment, in the frame of the previous pose) and one correction.
  void update(const Pose2D& odometry_increment, const LaserScan& scan);
  void update(const Pose2D& odometry_increment, const mrpt::obs::CObservation2DRangeScan& scan);

  PoseEstimate2D estimate() const;
  bool converged() const;
  // Share of the last scans' endpoints (smoothed over updates) within 0.2 m (or a cell and a
  // half, on a coarser map) of a wall on the map, seen from the estimate: 1 when the scans fit.
  double scan_fit() const;
  std::size_t particle_count() const;
  // Rays the last update left out as shorter than the map predicts, and particles redrawn by the
  // depletion guard since the start.
  std::size_t last_short_readings() const;
  std::size_t injected_particles() const;

  // The scan as MRPT sees it (rays spread evenly over the aperture, sensor pose on the base).
  static std::shared_ptr<mrpt::obs::CObservation2DRangeScan> to_mrpt(const LaserScan& scan);

 private:
  void inject_if_depleted();
  // The rays that hit something the map does not hold, seen from the estimate moved by the
  // increment: shorter than predicted, in runs no wider than a person or furniture.
  std::vector<std::size_t> unmapped_rays(const Pose2D& odometry_increment,
                                         const mrpt::obs::CObservation2DRangeScan& scan) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
  LocalizerOptions options_;
};

// Standard deviations of an estimate: position (largest axis of the x-y ellipse) and yaw.
double position_std_m(const PoseEstimate2D& estimate);
double yaw_std_rad(const PoseEstimate2D& estimate);

// b expressed in a's frame (a^-1 * b), and its inverse (a * delta): odometry increments.
Pose2D pose_delta(const Pose2D& a, const Pose2D& b);
Pose2D pose_compose(const Pose2D& a, const Pose2D& delta);

// Each cell's distance to the nearest wall face, in cells, centre to centre (CV_32FC1, row = cell
// y). A wall face is where free space meets the rest: a cell is that close to a face when it is
// that close both to a free cell and to one that is not, so an endpoint deep inside a thick wall
// is as far off the map as one in the open.
cv::Mat wall_face_distance_cells(const mrpt::maps::COccupancyGridMap2D& map);

// The endpoints of the scan's valid rays, one ray in `step`, in the map frame with the base at
// `T_map_base` (rays spread evenly over the aperture, from the scan's sensor pose).
std::vector<Eigen::Vector2d> scan_endpoints_m(const Pose2D& T_map_base,
                                              const mrpt::obs::CObservation2DRangeScan& scan,
                                              std::size_t step = 1);

}  // namespace projtour::navigation
