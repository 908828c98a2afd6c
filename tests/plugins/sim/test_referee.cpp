// The referee over the whole content area: where the robot's warp puts the content against the
// perfect warp, and how much of its light misses the target.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim_world_rig.hpp"

namespace projtour::sim {
namespace {

using testing::aim_at_sign;
using testing::Rig;
using testing::true_pixels;

std::array<Eigen::Vector2d, 4> shifted(std::array<Eigen::Vector2d, 4> px, double dx, double dy) {
  for (auto& p : px) p += Eigen::Vector2d(dx, dy);
  return px;
}

TEST(SimRefereeArea, ZeroForThePerfectPixelsAndGrowsWithAnOffset) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  const auto exact = w.evaluate_projection("sign", px);
  ASSERT_TRUE(exact);
  EXPECT_LT(exact->area_error_mean_mm, 0.01);
  EXPECT_LT(exact->area_error_max_mm, 0.01);
  // 10 projector pixels at about 0.98 m with f = 1920 px: about 5.1 mm everywhere on the board.
  const auto off = w.evaluate_projection("sign", shifted(px, 10.0, 0.0));
  ASSERT_TRUE(off);
  EXPECT_NEAR(off->area_error_mean_mm, 10.0 * 0.98 / 1920.0 * 1000.0, 0.4);
  EXPECT_GE(off->area_error_max_mm, off->area_error_mean_mm);
  EXPECT_LT(off->area_error_max_mm, 1.2 * off->area_error_mean_mm);
  EXPECT_NEAR(off->area_error_mean_mm, off->mean_mm(), 0.3);
  // Content grown 5 % about its centre: nothing at the centre, most at the corners, where the
  // area's grid meets the corner figures.
  auto grown = px;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : px) centre += p / 4.0;
  for (auto& p : grown) p = centre + 1.05 * (p - centre);
  const auto scaled = w.evaluate_projection("sign", grown);
  ASSERT_TRUE(scaled);
  const double worst_corner_mm =
      *std::max_element(scaled->error_mm.begin(), scaled->error_mm.end());
  EXPECT_NEAR(scaled->area_error_max_mm, worst_corner_mm, 0.05);
  EXPECT_GT(scaled->area_error_max_mm, 1.5 * scaled->area_error_mean_mm);
  EXPECT_GT(scaled->area_error_mean_mm, 1.0);
}

TEST(SimRefereeArea, LightOffTheTarget) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  // The Model Points' quadrilateral lies well inside the board's face.
  EXPECT_EQ(w.evaluate_projection("sign", px)->light_off_target_fraction, 0.0);
  // 300 px (14 cm) to the side: the content's 20 cm spill a third over the board's edge, on
  // whatever is behind it.
  const double side =
      w.evaluate_projection("sign", shifted(px, 300.0, 0.0))->light_off_target_fraction;
  EXPECT_GT(side, 0.2);
  EXPECT_LT(side, 0.5);
  // Content beyond the projector's image is not lit at all, on the target or anywhere.
  EXPECT_EQ(w.evaluate_projection("sign", shifted(px, 3000.0, 0.0))->light_off_target_fraction,
            1.0);

  Rig missing(1, {2.0, 0.0, 0.0});
  missing.world.faults = {{"sign", "target_missing", {}, {}}};
  SimWorld& m = missing.make();
  m.advance(0.0);
  aim_at_sign(missing, m);
  EXPECT_EQ(m.evaluate_projection("sign", true_pixels(missing, m))->light_off_target_fraction, 1.0);
}

TEST(SimRefereeArea, APoleTakesTheLightButNotTheGeometry) {
  // The robot at 1.4 m, the pole 0.6 m in front of the sign: its shadow crosses the content.
  Rig rig(1, {1.6, 0.0, 0.0});
  rig.world.faults = {{"sign", "pole", {{"distance_m", 0.6}, {"diameter_m", 0.05}}, {}}};
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto truth = w.evaluate_projection("sign", true_pixels(rig, w));
  ASSERT_TRUE(truth);
  EXPECT_GT(truth->light_off_target_fraction, 0.05);
  EXPECT_LT(truth->light_off_target_fraction, 0.6);
  // Where the content lands is the target's business alone: perfect pixels are still perfect.
  EXPECT_LT(truth->area_error_max_mm, 0.01);
  EXPECT_LT(truth->mean_mm(), 0.01);
  // A pole beside the line of sight leaves the light alone.
  Rig beside(1, {1.6, 0.0, 0.0});
  beside.world.faults = {
      {"sign", "pole", {{"distance_m", 0.6}, {"diameter_m", 0.05}, {"offset_m", 0.5}}, {}}};
  SimWorld& b = beside.make();
  b.advance(0.0);
  aim_at_sign(beside, b);
  EXPECT_EQ(b.evaluate_projection("sign", true_pixels(beside, b))->light_off_target_fraction, 0.0);
}

TEST(SimRefereeArea, NoWarpNoFigures) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  // Four pixels on one spot carry no homography; the corner figures stay what they were.
  const std::array<Eigen::Vector2d, 4> spot = {px[0], px[0], px[0], px[0]};
  const auto truth = w.evaluate_projection("sign", spot);
  ASSERT_TRUE(truth);
  EXPECT_TRUE(std::isnan(truth->area_error_mean_mm));
  EXPECT_TRUE(std::isnan(truth->area_error_max_mm));
  EXPECT_TRUE(std::isnan(truth->light_off_target_fraction));
  EXPECT_LT(truth->error_mm[0], 0.01);
  EXPECT_GT(truth->error_mm[2], 10.0);
}

}  // namespace
}  // namespace projtour::sim
