#include "projtour_test/test_maps.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "projtour/navigation/occupancy_map.hpp"

namespace projtour::nav_test {

namespace {
void fill(mrpt::maps::COccupancyGridMap2D& m, double x0, double y0, double x1, double y1,
          float value) {
  for (double y = y0; y < y1; y += 0.025) {
    for (double x = x0; x < x1; x += 0.025) {
      m.setPos(static_cast<float>(x), static_cast<float>(y), value);
    }
  }
}
}  // namespace

std::filesystem::path write_corridor_map(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  mrpt::maps::COccupancyGridMap2D m(0.0f, 30.0f, 0.0f, 12.0f, 0.05f);
  m.fill(0.5f);
  fill(m, 0.9, 0.9, 29.1, 3.1, 0.0f);  // walls of the corridor
  fill(m, 1.0, 1.0, 29.0, 3.0, 1.0f);  // its free space
  for (int k = 0; k < 9; ++k) {
    const double x = 2.0 + 3.0 * k;
    fill(m, x, k % 2 == 0 ? 1.0 : 2.7, x + 0.3, k % 2 == 0 ? 1.3 : 3.0, 0.0f);
  }
  fill(m, 9.9, 5.9, 14.1, 10.1, 0.0f);  // the closed room's walls
  fill(m, 10.0, 6.0, 14.0, 10.0, 1.0f);
  const auto file = dir / "corridor.yaml";
  navigation::save_occupancy_grid_yaml(m, file);
  return file;
}

std::filesystem::path write_loop_map(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  mrpt::maps::COccupancyGridMap2D m(0.0f, 20.0f, 0.0f, 10.0f, 0.05f);
  m.fill(0.5f);
  fill(m, 0.9, 0.9, 19.1, 8.1, 0.0f);  // the outer walls
  fill(m, 1.0, 1.0, 19.0, 8.0, 1.0f);  // the loop's free space...
  fill(m, 3.0, 3.0, 17.0, 6.0, 0.0f);  // ...round the block between the corridors
  for (int k = 0; k < 5; ++k) {
    const double x = 4.0 + 3.0 * k;
    fill(m, x, 1.0, x + 0.3, 1.3, 0.0f);  // bumps on the outer walls, for the laser
    fill(m, x + 1.5, 7.7, x + 1.8, 8.0, 0.0f);
  }
  const auto file = dir / "loop.yaml";
  navigation::save_occupancy_grid_yaml(m, file);
  return file;
}

}  // namespace projtour::nav_test
