#pragma once
// A depth frame as a camera delivers it: millimetres, row-major, 0 = no reading.
#include <cstdint>
#include <vector>

#include "projtour/contract/pinhole.hpp"

namespace projtour {

struct DepthFrame {
  double t_s = 0.0;  // mission time of capture
  std::uint64_t sequence = 0;
  PinholeModel intrinsics;  // of the depth image
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> depth_mm;  // width * height

  std::uint16_t at(int u, int v) const { return depth_mm[static_cast<std::size_t>(v) * width + u]; }
  std::size_t valid_count() const;
};

}  // namespace projtour
