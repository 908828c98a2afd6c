#include "projtour/navigation/localizer.hpp"

#include <mrpt/bayes/CParticleFilter.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/random/RandomGenerators.h>
#include <mrpt/slam/CMonteCarloLocalization2D.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "projtour/navigation/path_planner.hpp"

namespace projtour::navigation {

struct Localizer::Impl {
  // The particle filter's map: the walls' boundary at 0 and every other cell free, or the map
  // itself (Field::occupied). Rays are cast on it too: the boundary is what a beam meets first.
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  mrpt::slam::CMonteCarloLocalization2D pdf;
  mrpt::bayes::CParticleFilter filter;
  mrpt::obs::CActionRobotMovement2D::TMotionModelOptions motion;
  // Distance from each cell to the boundary of free space (see the constructor).
  cv::Mat wall_distance_m;
  double x_min_m = 0.0, y_min_m = 0.0, resolution_m = 1.0;
  double fit = 1.0;
  // Depletion guard: the scan fit's short and long averages (augmented MCL's w_fast, w_slow).
  double fit_fast = 1.0, fit_slow = 1.0;
  std::size_t short_readings = 0;
  std::size_t injected = 0;
};

namespace {

// Endpoints within this of a wall count as fitting the map, or within a cell and a half on a
// coarse map: there the wall band's own cells lie a whole cell from free space, and "within
// 0.2 m" could never pass on 0.2 m cells.
constexpr double kFitDistanceM = 0.2;
constexpr double kFitDistanceCells = 1.5;
constexpr double kFitSmoothing = 0.5;  // weight of the newest scan
constexpr std::size_t kFitRays = 60;
// Augmented MCL's averaging rates (Thrun, Burgard & Fox, Probabilistic Robotics, table 8.3),
// per filter update. The long average spans ~50 updates (a few metres of driving).
constexpr double kFitFastRate = 0.3;
constexpr double kFitSlowRate = 0.02;
// Below this ratio of the averages the scans stopped fitting; above it, people passing by.
constexpr double kInjectBelowRatio = 0.7;
// An injected particle starts at this fraction of the best particle's weight: it barely moves
// the estimate, yet one scan that fits it far better than the cloud lets it take over.
constexpr double kInjectedLogWeight = -4.6;  // ln(0.01)
// A run of short readings wider than this (at its mean range) is not a person or a box; more
// than this share of the valid rays short is not a crowd but an estimate gone wrong.
constexpr double kUnmappedMaxWidthM = 1.5;
constexpr double kUnmappedMaxShare = 0.4;
// Nothing the map lacks makes a reading longer than the map predicts (glass and a missing wall
// aside, and those are few); more than this share of the valid rays long means the estimate is
// wrong, and then the short readings are the evidence that corrects it.
constexpr double kLongMaxShare = 0.1;
// A cell is occupied when it is more likely occupied than free.
constexpr float kOccupiedCellBelow = 0.5f;

// The walls' boundary: cells that are not free, touch a free cell, and lie within a cell of an
// occupied one (so the edge of unexplored space, unknown next to free, is not a wall). A ROS map's
// wall row facing the robot often loads as unknown just under occupied_thresh; it is the
// boundary, and the black cells behind it are not.
void paint_boundary(const mrpt::maps::COccupancyGridMap2D& map,
                    mrpt::maps::COccupancyGridMap2D& out) {
  const int rows = static_cast<int>(map.getSizeY()), cols = static_cast<int>(map.getSizeX());
  cv::Mat free_mask(rows, cols, CV_8UC1), occupied(rows, cols, CV_8UC1);
  for (int cy = 0; cy < rows; ++cy) {
    for (int cx = 0; cx < cols; ++cx) {
      const float v = map.getCell(cx, cy);
      free_mask.at<std::uint8_t>(cy, cx) = v > kFreeCellThreshold ? 255 : 0;
      occupied.at<std::uint8_t>(cy, cx) = v < kOccupiedCellBelow ? 255 : 0;
    }
  }
  const cv::Mat neighbours = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  cv::Mat near_free, near_occupied;
  cv::dilate(free_mask, near_free, neighbours);
  cv::dilate(occupied, near_occupied, neighbours);
  for (int cy = 0; cy < rows; ++cy) {
    for (int cx = 0; cx < cols; ++cx) {
      const bool wall = free_mask.at<std::uint8_t>(cy, cx) == 0 &&
                        near_free.at<std::uint8_t>(cy, cx) != 0 &&
                        near_occupied.at<std::uint8_t>(cy, cx) != 0;
      out.setCell(cx, cy, wall ? 0.0f : 1.0f);
    }
  }
}

// The grid's lower-left corner and cell size locate points in `wall_distance_m`.
struct WallField {
  const cv::Mat& distance_m;
  double x_min_m, y_min_m, resolution_m;
};

double scan_fit_at(const WallField& impl, const Pose2D& pose,
                   const mrpt::obs::CObservation2DRangeScan& scan) {
  const std::size_t step = std::max<std::size_t>(1, scan.getScanSize() / kFitRays);
  const std::vector<Eigen::Vector2d> ends = scan_endpoints_m(pose, scan, step);
  std::size_t fitting = 0;
  for (const Eigen::Vector2d& end : ends) {
    const int cx = static_cast<int>(std::floor((end.x() - impl.x_min_m) / impl.resolution_m));
    const int cy = static_cast<int>(std::floor((end.y() - impl.y_min_m) / impl.resolution_m));
    if (cx >= 0 && cy >= 0 && cx < impl.distance_m.cols && cy < impl.distance_m.rows &&
        impl.distance_m.at<float>(cy, cx) <
            std::max(kFitDistanceM, kFitDistanceCells * impl.resolution_m)) {
      ++fitting;
    }
  }
  return ends.empty() ? 1.0 : static_cast<double>(fitting) / static_cast<double>(ends.size());
}

}  // namespace

Localizer::Localizer(const mrpt::maps::COccupancyGridMap2D& map, const LocalizerOptions& options,
                     std::uint64_t seed)
    : impl_(std::make_unique<Impl>()), options_(options) {
  mrpt::random::getRandomGenerator().randomize(static_cast<std::uint32_t>(seed));
  impl_->map = std::make_shared<mrpt::maps::COccupancyGridMap2D>(map);
  if (options.lf_field == LocalizerOptions::Field::boundary) paint_boundary(map, *impl_->map);
  auto& likelihood = impl_->map->likelihoodOptions;
  likelihood.likelihoodMethod = mrpt::maps::COccupancyGridMap2D::lmLikelihoodField_Thrun;
  likelihood.LF_stdHit = static_cast<float>(options.lf_sigma_m);
  likelihood.LF_maxCorrsDistance = static_cast<float>(options.lf_max_corr_m);
  likelihood.LF_decimation = static_cast<std::uint32_t>(std::max(1, options.lf_decimation));
  likelihood.LF_zHit = 0.95f;
  likelihood.LF_zRandom = 0.05f;
  likelihood.enableLikelihoodCache = true;

  impl_->pdf.options.metricMap = impl_->map;
  impl_->x_min_m = map.getXMin();
  impl_->y_min_m = map.getYMin();
  impl_->resolution_m = map.getResolution();
  // Scans of a kidnapped robot end in the open or deep in unmapped space, not near a wall face.
  impl_->wall_distance_m = wall_face_distance_cells(map) * impl_->resolution_m;
  auto& pf = impl_->filter.m_options;
  pf.PF_algorithm = mrpt::bayes::CParticleFilter::pfStandardProposal;
  pf.resamplingMethod = mrpt::bayes::CParticleFilter::prSystematic;
  pf.adaptiveSampleSize = false;
  pf.BETA = options.resample_beta;

  auto& motion = impl_->motion;
  motion.modelSelection = mrpt::obs::CActionRobotMovement2D::mmGaussian;
  motion.gaussianModel.a1 = options.odom_trans_noise_frac;  // m per m
  motion.gaussianModel.a2 = 0.0;
  motion.gaussianModel.a3 = 0.0;
  motion.gaussianModel.a4 = options.odom_rot_noise_frac;  // rad per rad
  motion.gaussianModel.minStdXY = options.odom_min_std_m;
  motion.gaussianModel.minStdPHI = deg_to_rad(options.odom_min_std_deg);
}

Localizer::~Localizer() = default;

void Localizer::reset(const Pose2D& guess) {
  impl_->pdf.resetUniform(guess.x_m - options_.init_spread_m, guess.x_m + options_.init_spread_m,
                          guess.y_m - options_.init_spread_m, guess.y_m + options_.init_spread_m,
                          guess.yaw_rad - deg_to_rad(options_.init_spread_deg),
                          guess.yaw_rad + deg_to_rad(options_.init_spread_deg),
                          std::max(1, options_.particles));
  impl_->fit = impl_->fit_fast = impl_->fit_slow = 1.0;
}

void Localizer::widen(double spread_m, double spread_rad) {
  auto& random = mrpt::random::getRandomGenerator();
  for (auto& particle : impl_->pdf.m_particles) {
    particle.d.x += random.drawUniform(-spread_m, spread_m);
    particle.d.y += random.drawUniform(-spread_m, spread_m);
    particle.d.phi = wrap_angle_rad(particle.d.phi + random.drawUniform(-spread_rad, spread_rad));
    particle.log_w = 0.0;
  }
  // The fit said "lost"; give the widened cloud a fresh start.
  impl_->fit = impl_->fit_fast = impl_->fit_slow = 1.0;
}

std::shared_ptr<mrpt::obs::CObservation2DRangeScan> Localizer::to_mrpt(const LaserScan& scan) {
  auto obs = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
  const std::size_t n = scan.ranges_m.size();
  obs->resizeScan(n);
  obs->maxRange = static_cast<float>(scan.max_range_m);
  obs->rightToLeft = scan.angle_increment_rad >= 0.0;
  const double span_rad = scan.angle_increment_rad * (n > 0 ? static_cast<double>(n - 1) : 0.0);
  obs->aperture = static_cast<float>(std::abs(span_rad));
  for (std::size_t i = 0; i < n; ++i) {
    const float r = scan.ranges_m[i];
    const bool valid = (i >= scan.valid.size() || scan.valid[i] != 0) && std::isfinite(r) &&
                       r > 0.0f && r < scan.max_range_m;
    obs->setScanRange(i, valid ? r : static_cast<float>(scan.max_range_m));
    obs->setScanRangeValidity(i, valid);
  }
  // MRPT spreads the rays symmetrically about the sensor's x axis; a scan whose middle ray
  // points elsewhere has its sensor frame turned by that much.
  const double centre_rad = scan.angle_min_rad + 0.5 * span_rad;
  const Pose2D mount = pose2d_from_isometry(scan.T_base_laser);
  obs->sensorPose = mrpt::poses::CPose3D(mount.x_m, mount.y_m, scan.T_base_laser.translation().z(),
                                         wrap_angle_rad(mount.yaw_rad + centre_rad), 0.0, 0.0);
  obs->timestamp = mrpt::Clock::fromDouble(scan.t_s);
  return obs;
}

std::vector<std::size_t> Localizer::unmapped_rays(
    const Pose2D& odometry_increment, const mrpt::obs::CObservation2DRangeScan& scan) const {
  // Predicted from where the robot will be after this increment: the prediction's own error is
  // the cloud's, well inside the margin once converged.
  const Pose2D at = pose_compose(estimate().mean, odometry_increment);
  mrpt::obs::CObservation2DRangeScan expected = scan;
  impl_->map->laserScanSimulator(expected, mrpt::poses::CPose2D(at.x_m, at.y_m, at.yaw_rad), 0.5f,
                                 scan.getScanSize());
  const std::size_t n = scan.getScanSize();
  const double step_rad = n > 1 ? scan.aperture / static_cast<double>(n - 1) : 0.0;
  std::vector<std::size_t> out;
  std::size_t valid = 0, long_rays = 0;
  // Runs of consecutive short rays: only a run no wider than a person or a piece of furniture is
  // something the map does not hold. A wider one is more likely the map's own wall, nearer than
  // the estimate thinks (a robot carried along a corridor sees the end wall early): those
  // readings are what pulls the estimate back, and they stay.
  bool in_run = false;
  std::size_t run_start = 0;
  double run_sum_m = 0.0;
  auto close_run = [&](std::size_t end) {
    // Width at the run's mean range: mean range times the angle it spans.
    if (in_run && run_sum_m * step_rad <= kUnmappedMaxWidthM) {
      for (std::size_t i = run_start; i < end; ++i) out.push_back(i);
    }
    in_run = false;
    run_sum_m = 0.0;
  };
  for (std::size_t i = 0; i < n; ++i) {
    bool is_short = false;
    if (scan.getScanRangeValidity(i)) {
      ++valid;
      const float predicted_m =
          expected.getScanRangeValidity(i) ? expected.getScanRange(i) : scan.maxRange;
      is_short = scan.getScanRange(i) < predicted_m - options_.short_reading_m;
      if (scan.getScanRange(i) > predicted_m + options_.short_reading_m) ++long_rays;
    }
    if (is_short) {
      if (!in_run) run_start = i;
      in_run = true;
      run_sum_m += scan.getScanRange(i);
    } else {
      close_run(i);
    }
  }
  close_run(n);
  // So much unmapped is more likely an estimate gone wrong than a crowd: leave nothing out.
  if (out.size() > kUnmappedMaxShare * static_cast<double>(valid) ||
      static_cast<double>(long_rays) > kLongMaxShare * static_cast<double>(valid)) {
    out.clear();
  }
  return out;
}

void Localizer::update(const Pose2D& odometry_increment, const LaserScan& scan) {
  update(odometry_increment, *to_mrpt(scan));
}

void Localizer::update(const Pose2D& odometry_increment,
                       const mrpt::obs::CObservation2DRangeScan& scan) {
  auto used = std::make_shared<mrpt::obs::CObservation2DRangeScan>(scan);
  impl_->short_readings = 0;
  // Not while the depletion guard sees the scans stop fitting: then the estimate is in doubt, and
  // so is every prediction made from it.
  const bool fitting =
      impl_->fit_slow <= 0.0 || impl_->fit_fast >= kInjectBelowRatio * impl_->fit_slow;
  if (options_.short_reading_m > 0.0 && converged() && fitting) {
    const std::vector<std::size_t> left_out = unmapped_rays(odometry_increment, scan);
    for (std::size_t i : left_out) used->setScanRangeValidity(i, false);
    impl_->short_readings = left_out.size();
  }

  mrpt::obs::CActionRobotMovement2D movement;
  movement.computeFromOdometry(mrpt::poses::CPose2D(odometry_increment.x_m, odometry_increment.y_m,
                                                    odometry_increment.yaw_rad),
                               impl_->motion);
  mrpt::obs::CActionCollection actions;
  actions.insert(movement);
  mrpt::obs::CSensoryFrame frame;
  frame.insert(used);
  impl_->filter.executeOn(impl_->pdf, &actions, &frame);
  const WallField walls{impl_->wall_distance_m, impl_->x_min_m, impl_->y_min_m,
                        impl_->resolution_m};
  // On every ray, the left-out ones too: a kidnapped robot's readings are mostly "short", and
  // its fit must still fall.
  const double fit = scan_fit_at(walls, estimate().mean, scan);
  impl_->fit = (1.0 - kFitSmoothing) * impl_->fit + kFitSmoothing * fit;
  impl_->fit_fast += kFitFastRate * (fit - impl_->fit_fast);
  impl_->fit_slow += kFitSlowRate * (fit - impl_->fit_slow);
  inject_if_depleted();
}

void Localizer::inject_if_depleted() {
  if (options_.inject_max_frac <= 0.0 || impl_->fit_slow <= 0.0) return;
  const double ratio = impl_->fit_fast / impl_->fit_slow;
  if (ratio >= kInjectBelowRatio) return;
  const double share = std::min(options_.inject_max_frac, 1.0 - ratio);
  auto& particles = impl_->pdf.m_particles;
  const auto count = static_cast<std::size_t>(std::floor(share * particles.size()));
  if (count == 0) return;
  const Pose2D mean = estimate().mean;
  double best_log_w = -std::numeric_limits<double>::infinity();
  for (const auto& p : particles) best_log_w = std::max(best_log_w, p.log_w);
  // The least likely particles make way: the ones on their way to the robot stay.
  std::vector<std::size_t> order(particles.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(count), order.end(),
                    [&](std::size_t a, std::size_t b) {
                      return particles[a].log_w < particles[b].log_w ||
                             (particles[a].log_w == particles[b].log_w && a < b);
                    });
  auto& random = mrpt::random::getRandomGenerator();
  const double spread_rad = deg_to_rad(options_.inject_spread_deg);
  for (std::size_t k = 0; k < count; ++k) {
    auto& p = particles[order[k]];
    p.d.x = mean.x_m + random.drawUniform(-options_.inject_spread_m, options_.inject_spread_m);
    p.d.y = mean.y_m + random.drawUniform(-options_.inject_spread_m, options_.inject_spread_m);
    p.d.phi = wrap_angle_rad(mean.yaw_rad + random.drawUniform(-spread_rad, spread_rad));
    p.log_w = std::min(p.log_w, best_log_w + kInjectedLogWeight);
  }
  impl_->injected += count;
}

double Localizer::scan_fit() const {
  return impl_->fit;
}

PoseEstimate2D Localizer::estimate() const {
  const auto [cov, mean] = impl_->pdf.getCovarianceAndMean();
  PoseEstimate2D out;
  out.mean = Pose2D{mean.x(), mean.y(), wrap_angle_rad(mean.phi())};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.covariance(r, c) = cov(r, c);
  }
  return out;
}

bool Localizer::converged() const {
  const PoseEstimate2D e = estimate();
  return position_std_m(e) < options_.converged_std_m &&
         yaw_std_rad(e) < deg_to_rad(options_.converged_std_deg) &&
         impl_->fit >= options_.converged_min_fit;
}

std::size_t Localizer::particle_count() const {
  return impl_->pdf.size();
}

std::size_t Localizer::last_short_readings() const {
  return impl_->short_readings;
}

std::size_t Localizer::injected_particles() const {
  return impl_->injected;
}

std::vector<Eigen::Vector2d> scan_endpoints_m(const Pose2D& T_map_base,
                                              const mrpt::obs::CObservation2DRangeScan& scan,
                                              std::size_t step) {
  const std::size_t n = scan.getScanSize();
  std::vector<Eigen::Vector2d> out;
  if (n < 2) return out;
  const Pose2D sensor = pose_compose(
      T_map_base, Pose2D{scan.sensorPose.x(), scan.sensorPose.y(), scan.sensorPose.yaw()});
  out.reserve(n / std::max<std::size_t>(step, 1) + 1);
  for (std::size_t i = 0; i < n; i += std::max<std::size_t>(step, 1)) {
    if (!scan.getScanRangeValidity(i)) continue;
    const double a = (scan.rightToLeft ? 1.0 : -1.0) *
                     (-0.5 * scan.aperture + i * scan.aperture / static_cast<double>(n - 1));
    const double r = scan.getScanRange(i);
    const Pose2D end = pose_compose(sensor, Pose2D{r * std::cos(a), r * std::sin(a), 0.0});
    out.emplace_back(end.x_m, end.y_m);
  }
  return out;
}

cv::Mat wall_face_distance_cells(const mrpt::maps::COccupancyGridMap2D& map) {
  cv::Mat free_mask(static_cast<int>(map.getSizeY()), static_cast<int>(map.getSizeX()), CV_8UC1);
  for (int cy = 0; cy < free_mask.rows; ++cy) {
    for (int cx = 0; cx < free_mask.cols; ++cx) {
      free_mask.at<std::uint8_t>(cy, cx) = map.getCell(cx, cy) > kFreeCellThreshold ? 255 : 0;
    }
  }
  // distanceTransform measures to the nearest zero pixel.
  cv::Mat to_free, to_not_free;
  cv::distanceTransform(free_mask, to_not_free, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::distanceTransform(255 - free_mask, to_free, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  return cv::max(to_free, to_not_free);
}

double position_std_m(const PoseEstimate2D& estimate) {
  const Eigen::Matrix2d xy = estimate.covariance.topLeftCorner<2, 2>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(xy);
  return std::sqrt(std::max(0.0, solver.eigenvalues().maxCoeff()));
}

double yaw_std_rad(const PoseEstimate2D& estimate) {
  return std::sqrt(std::max(0.0, estimate.covariance(2, 2)));
}

Pose2D pose_delta(const Pose2D& a, const Pose2D& b) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  const double dx = b.x_m - a.x_m, dy = b.y_m - a.y_m;
  return Pose2D{c * dx + s * dy, -s * dx + c * dy, wrap_angle_rad(b.yaw_rad - a.yaw_rad)};
}

Pose2D pose_compose(const Pose2D& a, const Pose2D& delta) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return Pose2D{a.x_m + c * delta.x_m - s * delta.y_m, a.y_m + s * delta.x_m + c * delta.y_m,
                wrap_angle_rad(a.yaw_rad + delta.yaw_rad)};
}

}  // namespace projtour::navigation
