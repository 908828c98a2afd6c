// The beam guard on a synthetic frame: a wall 2 m away lit over the image's centre, and a pole
// 1 m away in the light. What it finds in the beam, and whether a later frame sees that place
// clear: a dropped frame, or one without readings where the pole stood, never does.
#include <gtest/gtest.h>

#include "projtour/light/beam_guard.hpp"

namespace projtour {
namespace {

constexpr int kW = 160, kH = 120;

PinholeModel pinhole() {
  PinholeModel k;
  k.width = kW;
  k.height = kH;
  k.fx = k.fy = 120.0;
  k.cx = 79.5;
  k.cy = 59.5;
  return k;
}

// The wall at 2 m everywhere, the pole (columns 76..83, every row) at pole_mm; 0 = none there.
DepthFrame frame_with_pole(std::uint16_t pole_mm, double t_s = 1.0) {
  DepthFrame f;
  f.t_s = t_s;
  f.intrinsics = pinhole();
  f.width = kW;
  f.height = kH;
  f.depth_mm.assign(static_cast<std::size_t>(kW) * kH, 2000);
  for (int v = 0; v < kH; ++v) {
    for (int u = 76; u < 84; ++u) f.depth_mm[static_cast<std::size_t>(v) * kW + u] = pole_mm;
  }
  return f;
}

DepthFrame dropped() {
  DepthFrame f = frame_with_pole(0);
  std::fill(f.depth_mm.begin(), f.depth_mm.end(), 0);
  return f;
}

// Armed with the projector at the camera, lighting the middle half of the image, the target a
// flat patch of the wall.
light::BeamGuard armed_guard() {
  ModelCloud wall;
  for (int i = -5; i <= 5; ++i) {
    for (int j = -5; j <= 5; ++j) wall.points.emplace_back(0.05f * i, 0.05f * j, 2.0f);
  }
  light::BeamGuard guard;
  guard.arm(Eigen::Isometry3d::Identity(), pinhole(),
            {Eigen::Vector2d(40, 30), Eigen::Vector2d(120, 30), Eigen::Vector2d(120, 90),
             Eigen::Vector2d(40, 90)},
            wall, Eigen::Isometry3d::Identity());
  return guard;
}

TEST(BeamGuard, APoleInTheLightIsInTheBeamAndItsPixelsAreNamed) {
  const light::BeamGuard guard = armed_guard();
  ASSERT_TRUE(guard.armed());
  std::vector<std::size_t> px;
  const light::BeamIntrusion seen =
      guard.check(frame_with_pole(1000), Eigen::Vector3d::Zero(), &px);
  EXPECT_TRUE(seen.blocked);
  EXPECT_EQ(static_cast<std::size_t>(seen.points), px.size());
  EXPECT_NEAR(seen.nearest_m, 1.0, 1e-9);
  for (const std::size_t i : px) {
    const int u = static_cast<int>(i % kW);
    EXPECT_TRUE(u >= 76 && u < 84) << u;
  }
  EXPECT_FALSE(guard.check(frame_with_pole(2000), Eigen::Vector3d::Zero()).blocked);
}

TEST(BeamGuard, OnlyReadingsOutOfTheBeamWhereThePoleStoodSeeItGone) {
  const light::BeamGuard guard = armed_guard();
  std::vector<std::size_t> px;
  guard.check(frame_with_pole(1000), Eigen::Vector3d::Zero(), &px);
  ASSERT_FALSE(px.empty());
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  EXPECT_EQ(guard.seen_clear(frame_with_pole(2000), none, px), px.size()) << "the pole gone";
  EXPECT_EQ(guard.seen_clear(frame_with_pole(1000), none, px), 0u) << "the pole still there";
  // A dropped frame is clear of everything to check(), and sees nothing clear.
  EXPECT_FALSE(guard.check(dropped(), none).blocked);
  EXPECT_EQ(guard.seen_clear(dropped(), none, px), 0u);
  // Most of the frame read, none of it where the pole stood: a black coat, a part-dropped frame.
  const DepthFrame holes = frame_with_pole(0);
  EXPECT_GT(2 * holes.valid_count(), holes.depth_mm.size());
  EXPECT_FALSE(guard.check(holes, none).blocked);
  EXPECT_EQ(guard.seen_clear(holes, none, px), 0u);
}

}  // namespace
}  // namespace projtour
