#pragma once
// Small synthetic maps for the failure outcomes, written as map_server YAML + PNG.
#include <filesystem>
#include <string>

namespace projtour::nav_test {

// 30 m x 12 m at 0.05 m: a 2 m wide corridor along y in [1, 3] from x = 1 to 29 with bumps on
// its walls every 3 m (so the laser can tell where along it the robot is), and a closed room,
// x in [10, 14], y in [6, 10], that nothing leads into.
std::filesystem::path write_corridor_map(const std::filesystem::path& dir);

// 20 m x 10 m at 0.05 m: a loop of 2 m corridors round a block, x in [3, 17], y in [3, 6]; the
// lower corridor is y in [1, 3], the upper y in [6, 8], joined at both ends. Closing the lower
// corridor at x = 9 leaves a way round some 30 m longer.
std::filesystem::path write_loop_map(const std::filesystem::path& dir);

}  // namespace projtour::nav_test
