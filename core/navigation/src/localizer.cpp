#include "projtour/localizer.hpp"

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

#include <opencv2/imgproc.hpp>

#include "projtour/path_planner.hpp"

namespace projtour {

struct Localizer::Impl {
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  mrpt::slam::CMonteCarloLocalization2D pdf;
  mrpt::bayes::CParticleFilter filter;
  mrpt::obs::CActionRobotMovement2D::TMotionModelOptions motion;
  // Distance from each cell to the boundary of free space (see the constructor).
  cv::Mat wall_distance_m;
  double x_min_m = 0.0, y_min_m = 0.0, resolution_m = 1.0;
  double fit = 1.0;
};

namespace {

// Endpoints within this of a wall count as fitting the map, or within a cell and a half on a
// coarse map: there the wall band's own cells lie a whole cell from free space, and "within
// 0.2 m" could never pass on 0.2 m cells.
constexpr double kFitDistanceM = 0.2;
constexpr double kFitDistanceCells = 1.5;
constexpr double kFitSmoothing = 0.5;  // weight of the newest scan
constexpr std::size_t kFitRays = 60;

// The grid's lower-left corner and cell size locate points in `wall_distance_m`.
struct WallField {
  const cv::Mat& distance_m;
  double x_min_m, y_min_m, resolution_m;
};

double scan_fit_at(const WallField& impl, const Pose2D& pose,
                   const mrpt::obs::CObservation2DRangeScan& scan) {
  const std::size_t n = scan.getScanSize();
  if (n < 2) return 1.0;
  const Pose2D sensor =
      pose_compose(pose, Pose2D{scan.sensorPose.x(), scan.sensorPose.y(), scan.sensorPose.yaw()});
  const std::size_t step = std::max<std::size_t>(1, n / kFitRays);
  std::size_t valid = 0, fitting = 0;
  for (std::size_t i = 0; i < n; i += step) {
    if (!scan.getScanRangeValidity(i)) continue;
    const double a = (scan.rightToLeft ? 1.0 : -1.0) *
                     (-0.5 * scan.aperture + i * scan.aperture / static_cast<double>(n - 1));
    const double r = scan.getScanRange(i);
    const Pose2D end = pose_compose(sensor, Pose2D{r * std::cos(a), r * std::sin(a), 0.0});
    ++valid;
    const int cx = static_cast<int>(std::floor((end.x_m - impl.x_min_m) / impl.resolution_m));
    const int cy = static_cast<int>(std::floor((end.y_m - impl.y_min_m) / impl.resolution_m));
    if (cx >= 0 && cy >= 0 && cx < impl.distance_m.cols && cy < impl.distance_m.rows &&
        impl.distance_m.at<float>(cy, cx) <
            std::max(kFitDistanceM, kFitDistanceCells * impl.resolution_m)) {
      ++fitting;
    }
  }
  return valid == 0 ? 1.0 : static_cast<double>(fitting) / valid;
}

}  // namespace

Localizer::Localizer(const mrpt::maps::COccupancyGridMap2D& map, const LocalizerOptions& options,
                     std::uint64_t seed)
    : impl_(std::make_unique<Impl>()), options_(options) {
  mrpt::random::getRandomGenerator().randomize(static_cast<std::uint32_t>(seed));
  impl_->map = std::make_shared<mrpt::maps::COccupancyGridMap2D>(map);
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
  // A wall is where free space meets the rest: a cell is that close to a wall when it is that
  // close both to a free cell and to one that is not free. Scans of a kidnapped robot end in
  // the open or deep in unmapped space, not on this band.
  cv::Mat not_free(static_cast<int>(map.getSizeY()), static_cast<int>(map.getSizeX()), CV_8UC1);
  for (int cy = 0; cy < not_free.rows; ++cy) {
    for (int cx = 0; cx < not_free.cols; ++cx) {
      not_free.at<std::uint8_t>(cy, cx) = map.getCell(cx, cy) > kFreeCellThreshold ? 255 : 0;
    }
  }
  cv::Mat to_not_free, to_free;
  cv::distanceTransform(not_free, to_not_free, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::Mat free_mask = 255 - not_free;
  cv::distanceTransform(free_mask, to_free, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  impl_->wall_distance_m = cv::max(to_not_free, to_free);
  impl_->wall_distance_m *= impl_->resolution_m;
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
  impl_->fit = 1.0;
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
  impl_->fit = 1.0;
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

void Localizer::update(const Pose2D& odometry_increment, const LaserScan& scan) {
  update(odometry_increment, *to_mrpt(scan));
}

void Localizer::update(const Pose2D& odometry_increment,
                       const mrpt::obs::CObservation2DRangeScan& scan) {
  mrpt::obs::CActionRobotMovement2D movement;
  movement.computeFromOdometry(mrpt::poses::CPose2D(odometry_increment.x_m, odometry_increment.y_m,
                                                    odometry_increment.yaw_rad),
                               impl_->motion);
  mrpt::obs::CActionCollection actions;
  actions.insert(movement);
  mrpt::obs::CSensoryFrame frame;
  frame.insert(std::make_shared<mrpt::obs::CObservation2DRangeScan>(scan));
  impl_->filter.executeOn(impl_->pdf, &actions, &frame);
  const WallField walls{impl_->wall_distance_m, impl_->x_min_m, impl_->y_min_m,
                        impl_->resolution_m};
  const double fit = scan_fit_at(walls, estimate().mean, scan);
  impl_->fit = (1.0 - kFitSmoothing) * impl_->fit + kFitSmoothing * fit;
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

}  // namespace projtour
