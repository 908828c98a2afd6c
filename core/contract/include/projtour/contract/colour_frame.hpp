#pragma once
// A colour frame as the camera delivers it: 8-bit BGR, row-major, time-stamped like depth frames.
#include <cstdint>
#include <vector>

#include "projtour/contract/pinhole.hpp"

namespace projtour {

struct ColourFrame {
  double t_s = 0.0;  // mission time of capture (mid-exposure)
  std::uint64_t sequence = 0;
  PinholeModel intrinsics;  // of the colour image, with its lens distortion
  int width = 0;
  int height = 0;
  double exposure_ms = 0.0;       // what the camera really used
  std::vector<std::uint8_t> bgr;  // width * height * 3

  const std::uint8_t* pixel(int u, int v) const {
    return bgr.data() + (static_cast<std::size_t>(v) * width + u) * 3;
  }
};

}  // namespace projtour
