// The localizer's fit monitor at any map resolution (issue 14): a wall band's own cells lie a cell
// from free space, so on a 0.2 m/cell map a "within 0.2 m of a wall" test could never pass and a
// robot standing still in a room it fits perfectly read as lost.
#include <gtest/gtest.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>

#include "projtour/localizer.hpp"

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

class FitAtResolution : public ::testing::TestWithParam<double> {};

TEST_P(FitAtResolution, AStillRobotThatFitsTheRoomIsConverged) {
  const mrpt::maps::COccupancyGridMap2D map = room(GetParam());
  const Pose2D truth{2.0, 2.5, 0.3};
  mrpt::obs::CObservation2DRangeScan scan;
  scan.aperture = static_cast<float>(deg_to_rad(270.0));
  scan.maxRange = 20.0f;
  scan.rightToLeft = true;
  map.laserScanSimulator(scan, mrpt::poses::CPose2D(truth.x_m, truth.y_m, truth.yaw_rad), 0.5f, 541,
                         0.01f);
  Localizer localizer(map, LocalizerOptions{}, 3);
  localizer.reset(truth);
  for (int i = 0; i < 20; ++i) localizer.update(Pose2D{0, 0, 0}, scan);
  const PoseEstimate2D e = localizer.estimate();
  EXPECT_LT(std::hypot(e.mean.x_m - truth.x_m, e.mean.y_m - truth.y_m), 2.0 * GetParam());
  EXPECT_GT(localizer.scan_fit(), 0.9) << GetParam() << " m per cell";
  EXPECT_TRUE(localizer.converged()) << GetParam() << " m per cell";
}

INSTANTIATE_TEST_SUITE_P(Resolutions, FitAtResolution,
                         ::testing::Values(0.02, 0.05, 0.1, 0.2, 0.25));

}  // namespace
}  // namespace projtour
