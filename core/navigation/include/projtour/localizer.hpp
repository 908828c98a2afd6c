#pragma once
// Monte Carlo localization on an occupancy grid (MRPT's CMonteCarloLocalization2D driven by a
// CParticleFilter): odometry increments as the motion model, the laser's likelihood field on the
// map as the measurement model. The localization service and `projtour localize` share it.
#include <cstdint>
#include <memory>

#include "projtour/drivers.hpp"
#include "projtour/geometry.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}
namespace mrpt::obs {
class CObservation2DRangeScan;
}

namespace projtour {

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

  // The scan as MRPT sees it (rays spread evenly over the aperture, sensor pose on the base).
  static std::shared_ptr<mrpt::obs::CObservation2DRangeScan> to_mrpt(const LaserScan& scan);

 private:
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

}  // namespace projtour
