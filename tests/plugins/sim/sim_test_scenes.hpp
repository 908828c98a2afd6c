#pragma once
// Scenes shared by the sim tests and bench_render: a walled room, Kinect intrinsics, cameras.
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <filesystem>
#include <memory>
#include <string>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::sim::testing {

// ctest runs every test case as its own process, in parallel: a fixed /tmp name lets one case
// read a file another is rewriting (CI saw a half-written OFF), so each test gets its own.
inline std::filesystem::path test_temp_path(const std::string& name) {
  return test::scratch_dir() / name;
}

inline PinholeModel kinect_intrinsics() {
  PinholeModel k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 570.3;
  k.cx = 319.5;
  k.cy = 239.5;
  return k;
}

// A free room [x0, x1] x [y0, y1] with one-cell walls around it, at 5 cm.
inline std::shared_ptr<mrpt::maps::COccupancyGridMap2D> room_grid(float x0, float x1, float y0,
                                                                  float y1) {
  auto grid = std::make_shared<mrpt::maps::COccupancyGridMap2D>(x0 - 0.2f, x1 + 0.2f, y0 - 0.2f,
                                                                y1 + 0.2f, 0.05f);
  for (unsigned j = 0; j < grid->getSizeY(); ++j) {
    for (unsigned i = 0; i < grid->getSizeX(); ++i) {
      const double x = grid->idx2x(i), y = grid->idx2y(j);
      const bool inside = x > x0 && x < x1 && y > y0 && y < y1;
      const bool wall = !inside && x > x0 - 0.1 && x < x1 + 0.1 && y > y0 - 0.1 && y < y1 + 0.1;
      grid->setCell(static_cast<int>(i), static_cast<int>(j), inside ? 1.0f : (wall ? 0.0f : 0.5f));
    }
  }
  return grid;
}

// The optical frame (z forward) of a camera at (x, y, z) looking along yaw, pitched down by
// pitch_down_rad.
inline Eigen::Isometry3d camera_optical(double x, double y, double z, double yaw_rad,
                                        double pitch_down_rad) {
  return isometry_from_xyz_rpy(x, y, z, 0.0, pitch_down_rad, yaw_rad) * T_body_optical();
}

}  // namespace projtour::sim::testing
