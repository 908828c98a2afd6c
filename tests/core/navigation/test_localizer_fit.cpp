// The localizer's fit monitor at any map resolution (issue 14): a wall band's own cells lie a cell
// from free space, so on a 0.2 m/cell map a "within 0.2 m of a wall" test could never pass and a
// robot standing still in a room it fits perfectly read as lost.
#include <gtest/gtest.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>

#include "projtour/navigation/localizer.hpp"

namespace projtour {
namespace {

// A 10 x 6 m room with an inner wall stub, at `resolution_m` per cell: outside unknown, walls
// occupied, inside free.
mrpt::maps::COccupancyGridMap2D room(double resolution_m) {
  mrpt::maps::COccupancyGridMap2D grid(-1.0f, 11.0f, -1.0f, 7.0f, static_cast<float>(resolution_m));
  for (unsigned cy = 0; cy < grid.getSizeY(); ++cy) {
    for (unsigned cx = 0; cx < grid.getSizeX(); ++cx) {
      const double x = grid.idx2x(cx), y = grid.idx2y(cy);
      const bool inside = x > 0.0 && x < 10.0 && y > 0.0 && y < 6.0;
      const bool wall = (x > -0.3 && x < 10.3 && y > -0.3 && y < 6.3 && !inside) ||
                        (x > 4.0 && x < 4.3 && y > 0.0 && y < 3.0);
      grid.setCell(cx, cy, wall ? 0.0f : inside ? 1.0f : 0.5f);
    }
  }
  return grid;
}

mrpt::obs::CObservation2DRangeScan scan_from(const mrpt::maps::COccupancyGridMap2D& map,
                                             const Pose2D& pose) {
  mrpt::obs::CObservation2DRangeScan scan;
  scan.aperture = static_cast<float>(deg_to_rad(270.0));
  scan.maxRange = 20.0f;
  scan.rightToLeft = true;
  map.laserScanSimulator(scan, mrpt::poses::CPose2D(pose.x_m, pose.y_m, pose.yaw_rad), 0.5f, 541,
                         0.01f);
  return scan;
}

class FitAtResolution : public ::testing::TestWithParam<double> {};

TEST_P(FitAtResolution, AStillRobotThatFitsTheRoomIsConverged) {
  const mrpt::maps::COccupancyGridMap2D map = room(GetParam());
  const Pose2D truth{2.0, 2.5, 0.3};
  const mrpt::obs::CObservation2DRangeScan scan = scan_from(map, truth);
  navigation::Localizer localizer(map, navigation::LocalizerOptions{}, 3);
  localizer.reset(truth);
  for (int i = 0; i < 20; ++i) localizer.update(Pose2D{0, 0, 0}, scan);
  const PoseEstimate2D e = localizer.estimate();
  EXPECT_LT(std::hypot(e.mean.x_m - truth.x_m, e.mean.y_m - truth.y_m), 2.0 * GetParam());
  EXPECT_GT(localizer.scan_fit(), 0.9) << GetParam() << " m per cell";
  EXPECT_TRUE(localizer.converged()) << GetParam() << " m per cell";
}

INSTANTIATE_TEST_SUITE_P(Resolutions, FitAtResolution,
                         ::testing::Values(0.02, 0.05, 0.1, 0.2, 0.25));

double position_error_m(const navigation::Localizer& localizer, const Pose2D& truth) {
  const Pose2D m = localizer.estimate().mean;
  return std::hypot(m.x_m - truth.x_m, m.y_m - truth.y_m);
}

// A person 0.8 m ahead fills 40 degrees of the scan; once converged, those rays are left out
// (the map predicts a wall metres behind them) and the estimate does not move.
TEST(ShortReadings, APersonInFrontOfTheLaserIsLeftOut) {
  const mrpt::maps::COccupancyGridMap2D map = room(0.05);
  const Pose2D truth{2.0, 2.5, 0.0};
  const auto clear = scan_from(map, truth);
  auto with_person = clear;
  const std::size_t middle = clear.getScanSize() / 2;
  for (std::size_t i = middle - 40; i <= middle + 40; ++i) with_person.setScanRange(i, 0.8f);
  navigation::Localizer localizer(map, navigation::LocalizerOptions{}, 5);
  localizer.reset(truth);
  for (int i = 0; i < 15; ++i) localizer.update(Pose2D{}, clear);
  ASSERT_TRUE(localizer.converged());
  for (int i = 0; i < 15; ++i) {
    localizer.update(Pose2D{}, with_person);
    EXPECT_EQ(localizer.last_short_readings(), 81u) << "update " << i;
  }
  EXPECT_LT(position_error_m(localizer, truth), 0.05);
  EXPECT_TRUE(localizer.converged());
  localizer.update(Pose2D{}, clear);
  EXPECT_EQ(localizer.last_short_readings(), 0u);
}

// Before it converges nothing is left out: the estimate is not yet the robot's.
TEST(ShortReadings, NothingIsLeftOutBeforeConvergence) {
  const mrpt::maps::COccupancyGridMap2D map = room(0.05);
  navigation::LocalizerOptions options;
  options.init_spread_m = 2.0;
  options.init_spread_deg = 90.0;
  navigation::Localizer localizer(map, options, 5);
  localizer.reset(Pose2D{5.0, 3.0, 0.0});
  ASSERT_FALSE(localizer.converged());
  localizer.update(Pose2D{}, scan_from(map, Pose2D{2.0, 2.5, 0.0}));
  EXPECT_EQ(localizer.last_short_readings(), 0u);
}

// The depletion guard: the robot is carried 1.2 m and turned 17 degrees with no odometry (a
// push, a wheel slip). The tight cloud's own diffusion takes ~50 updates to find it; particles
// redrawn near the estimate when the fit drops find it within 15.
TEST(DepletionGuard, ACarriedRobotIsFoundAgainQuickly) {
  const mrpt::maps::COccupancyGridMap2D map = room(0.05);
  const Pose2D before{7.0, 4.0, 0.2}, after{8.0, 3.2, -0.1};
  auto run = [&](double inject_max_frac) {
    navigation::LocalizerOptions options;
    options.inject_max_frac = inject_max_frac;
    auto localizer = std::make_unique<navigation::Localizer>(map, options, 2);
    localizer->reset(before);
    for (int i = 0; i < 15; ++i) localizer->update(Pose2D{}, scan_from(map, before));
    EXPECT_LT(position_error_m(*localizer, before), 0.05);
    for (int i = 0; i < 15; ++i) localizer->update(Pose2D{}, scan_from(map, after));
    return localizer;
  };
  const auto guarded = run(navigation::LocalizerOptions{}.inject_max_frac);
  EXPECT_LT(position_error_m(*guarded, after), 0.05);
  EXPECT_GT(guarded->injected_particles(), 0u);
  EXPECT_TRUE(guarded->converged());
  const auto unguarded = run(0.0);
  EXPECT_GT(position_error_m(*unguarded, after), 0.3);
  EXPECT_EQ(unguarded->injected_particles(), 0u);
}

// A robot that stays where it is, fitting the map, never has particles redrawn.
TEST(DepletionGuard, QuietWhileTheScansFit) {
  const mrpt::maps::COccupancyGridMap2D map = room(0.1);
  const Pose2D truth{7.0, 4.0, -1.0};
  navigation::Localizer localizer(map, navigation::LocalizerOptions{}, 2);
  localizer.reset(truth);
  for (int i = 0; i < 60; ++i) localizer.update(Pose2D{}, scan_from(map, truth));
  EXPECT_EQ(localizer.injected_particles(), 0u);
}

}  // namespace
}  // namespace projtour
