#pragma once
// How maps/malaga_campus.* is made from MRPT's MalagaCampus grid; shared by the generator and
// the test that checks the committed files still match their source.
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <cmath>

namespace projtour::demo_map {

// The corridor part of the campus (the four long parallel corridors and the two that join
// them), in the source map's coordinates. Everything north of y = 10 m is the open hall.
inline constexpr float kXMinM = -10.0f, kXMaxM = 78.0f, kYMinM = -120.0f, kYMaxM = 10.0f;

// SLAM left the free space speckled (cells seen free a few times less often than others) and
// never-seen cells at exactly 0.5: walls below 0.35 stay occupied, untouched cells stay unknown,
// everything else observed is free.
inline float classify(float free_p) {
  if (free_p < 0.35f) return 0.0f;
  if (std::abs(free_p - 0.5f) < 0.02f) return 0.5f;
  return 1.0f;
}

inline mrpt::maps::COccupancyGridMap2D crop_and_classify(
    const mrpt::maps::COccupancyGridMap2D& source) {
  mrpt::maps::COccupancyGridMap2D out(kXMinM, kXMaxM, kYMinM, kYMaxM, source.getResolution());
  for (unsigned cy = 0; cy < out.getSizeY(); ++cy) {
    for (unsigned cx = 0; cx < out.getSizeX(); ++cx) {
      const float free_p = source.getPos(out.idx2x(cx), out.idx2y(cy));
      out.setCell(static_cast<int>(cx), static_cast<int>(cy), classify(free_p));
    }
  }
  return out;
}

}  // namespace projtour::demo_map
