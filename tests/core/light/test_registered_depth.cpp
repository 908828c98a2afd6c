// Depth registered into the colour image and colour pixels lifted to 3-D, against the analytic
// scene: exact placement without noise, Kinect noise averaged by the plane fit, and edges where
// the window holds two surfaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "light_scene.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/light/registered_depth.hpp"

namespace projtour {
namespace {

using light::lift;
using light::register_depth;
using light::RegisteredDepth;

std::optional<Eigen::Vector3d> truth(const test::LightRig& rig, const test::Scene& scene,
                                     const Eigen::Vector2d& px, int* surface = nullptr) {
  const Eigen::Vector3d ray = rig.colour.unproject(px).normalized();
  const auto hit = scene.intersect(Eigen::Vector3d::Zero(), ray);
  if (!hit) return std::nullopt;
  if (surface) *surface = hit->surface;
  return Eigen::Vector3d(hit->t * ray);
}

// Pixels whose window (`margin_px` about them) lies on surface 0 only.
std::vector<Eigen::Vector2d> inside_target(const test::LightRig& rig, const test::Scene& scene,
                                           int margin_px, int step_px) {
  std::vector<Eigen::Vector2d> pixels;
  for (int v = margin_px; v < rig.colour.height - margin_px; v += step_px) {
    for (int u = margin_px; u < rig.colour.width - margin_px; u += step_px) {
      bool inside = true;
      for (int dv : {-margin_px, 0, margin_px}) {
        for (int du : {-margin_px, 0, margin_px}) {
          int surface = -1;
          truth(rig, scene, Eigen::Vector2d(u + du, v + dv), &surface);
          inside = inside && surface == 0;
        }
      }
      if (inside) pixels.emplace_back(u, v);
    }
  }
  return pixels;
}

TEST(RegisteredDepth, NoiselessSignLandsWhereTheColourCameraSeesIt) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::sign_scene();
  const RegisteredDepth r =
      register_depth(test::render_depth(rig, scene, 1, false), rig.depth_to_color_m, rig.colour);
  ASSERT_EQ(r.z_m.size(), 640u * 480u);
  ASSERT_EQ(r.points_camera.size(), 640u * 480u);
  int pixels = 0, covered = 0;
  double worst_mm = 0.0;
  for (const Eigen::Vector2d& px : inside_target(rig, scene, 3, 1)) {
    ++pixels;
    const int u = static_cast<int>(px.x()), v = static_cast<int>(px.y());
    if (r.at(u, v) == 0.0f) continue;
    ++covered;
    // The reading that landed here came from within a pixel or so: on a sign turned by 10
    // degrees at 1.4 m, well under 1.5 mm of depth.
    worst_mm = std::max(worst_mm, 1000.0 * std::abs(r.at(u, v) - truth(rig, scene, px)->z()));
    const Eigen::Vector3f& p = r.points_camera[static_cast<std::size_t>(v) * 640 + u];
    EXPECT_EQ(p.z(), r.at(u, v));
    // A filled hole holds a diagonal neighbour's reading.
    EXPECT_LT((*rig.colour.project(p.cast<double>()) - px).norm(), 2.2) << u << "," << v;
  }
  std::printf("sign: %d of %d pixels covered, worst depth error %.2f mm\n", covered, pixels,
              worst_mm);
  EXPECT_GT(pixels, 15000);
  EXPECT_EQ(covered, pixels);  // the holes the lens leaves are filled
  EXPECT_LT(worst_mm, 1.5);
}

// One reading at a time, over the whole depth image: each lands on the colour pixel nearest to
// where PinholeModel::project puts it, lens distortion and all.
TEST(RegisteredDepth, ReadingsLandWherePinholeModelProjectsThem) {
  const test::LightRig rig = test::default_rig();
  DepthFrame frame;
  frame.intrinsics = rig.depth;
  frame.width = 640;
  frame.height = 480;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> mm(600, 3500);
  int placed = 0;
  for (int v = 0; v < 480; v += 37) {
    for (int u = 0; u < 640; u += 41) {
      frame.depth_mm.assign(640 * 480, 0);
      const int d = mm(rng);
      frame.depth_mm[static_cast<std::size_t>(v) * 640 + u] = static_cast<std::uint16_t>(d);
      const Eigen::Vector3d p = Eigen::Vector3d((u - rig.depth.cx) / rig.depth.fx,
                                                (v - rig.depth.cy) / rig.depth.fy, 1.0) *
                                    (d * 0.001) +
                                rig.depth_to_color_m;
      const Eigen::Vector2d px = *rig.colour.project(p);
      const RegisteredDepth r = register_depth(frame, rig.depth_to_color_m, rig.colour);
      const int cu = static_cast<int>(std::lround(px.x())),
                cv = static_cast<int>(std::lround(px.y()));
      if (!rig.colour.in_image(Eigen::Vector2d(cu, cv))) {
        EXPECT_EQ(std::count(r.z_m.begin(), r.z_m.end(), 0.0f), 640 * 480);
        continue;
      }
      ++placed;
      EXPECT_NEAR(r.at(cu, cv), p.z(), 1e-6) << u << "," << v;
      EXPECT_TRUE(r.points_camera[static_cast<std::size_t>(cv) * 640 + cu].isApprox(p.cast<float>(),
                                                                                    1e-6f));
    }
  }
  EXPECT_GT(placed, 150);
}

TEST(RegisteredDepth, HolesAreFilledOverTheWholeImage) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::sign_scene();
  const RegisteredDepth r =
      register_depth(test::render_depth(rig, scene, 1, false), rig.depth_to_color_m, rig.colour);
  // The wall fills the view. The depth camera sits 5 cm to the right, so it cannot see a band
  // at the left edge of the colour image, nor the wall just beside the sign (its shadow, some
  // 9 px wide at these depths); everything else is covered.
  int empty = 0, pixels = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 30; u < 640; ++u) {
      bool near_sign = false;
      for (int du = -12; du <= 12 && !near_sign; du += 4) {
        int surface = -1;
        truth(rig, scene, Eigen::Vector2d(u + du, v), &surface);
        near_sign = surface == 0;
      }
      if (near_sign) continue;
      ++pixels;
      empty += r.at(u, v) == 0.0f;
    }
  }
  std::printf("empty pixels on the wall: %d of %d\n", empty, pixels);
  EXPECT_GT(pixels, 250000);
  EXPECT_EQ(empty, 0);
}

struct LiftErrors {
  double rms_mm = 0.0, worst_mm = 0.0;
  int lifted = 0, asked = 0;
};

LiftErrors lift_errors(const test::LightRig& rig, const test::Scene& scene,
                       const RegisteredDepth& r, const std::vector<Eigen::Vector2d>& pixels) {
  LiftErrors e;
  double sum = 0.0;
  for (const Eigen::Vector2d& px : pixels) {
    ++e.asked;
    const auto p = lift(r, px);
    if (!p) continue;
    ++e.lifted;
    const double mm = 1000.0 * (*p - *truth(rig, scene, px)).norm();
    sum += mm * mm;
    e.worst_mm = std::max(e.worst_mm, mm);
  }
  e.rms_mm = e.lifted ? std::sqrt(sum / e.lifted) : 0.0;
  return e;
}

TEST(Lift, AveragesKinectNoiseOnTheSign) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::sign_scene();
  const RegisteredDepth r =
      register_depth(test::render_depth(rig, scene, 7), rig.depth_to_color_m, rig.colour);
  // Sub-pixel positions, as decoded centroids are.
  std::vector<Eigen::Vector2d> pixels = inside_target(rig, scene, 5, 7);
  for (Eigen::Vector2d& px : pixels) px += Eigen::Vector2d(0.31, -0.27);
  const LiftErrors e = lift_errors(rig, scene, r, pixels);
  std::printf("sign, 1.4 m: %d of %d lifted, rms %.2f mm, worst %.2f mm\n", e.lifted, e.asked,
              e.rms_mm, e.worst_mm);
  EXPECT_EQ(e.lifted, e.asked);
  EXPECT_LT(e.rms_mm, 1.0);  // one reading alone: ~3 mm
  EXPECT_LT(e.worst_mm, 3.0);
}

TEST(Lift, AveragesKinectNoiseOnThePillar) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::pillar_scene();
  const RegisteredDepth r =
      register_depth(test::render_depth(rig, scene, 8), rig.depth_to_color_m, rig.colour);
  // Its front, within 60 degrees of facing the camera.
  std::vector<Eigen::Vector2d> pixels;
  for (const Eigen::Vector2d& px : inside_target(rig, scene, 5, 7)) {
    if (std::abs(truth(rig, scene, px)->x()) < 0.16 * std::sin(deg_to_rad(60.0))) {
      pixels.push_back(px);
    }
  }
  const LiftErrors e = lift_errors(rig, scene, r, pixels);
  std::printf("pillar, 1.3 m: %d of %d lifted, rms %.2f mm, worst %.2f mm\n", e.lifted, e.asked,
              e.rms_mm, e.worst_mm);
  EXPECT_GT(e.lifted, 0.98 * e.asked);
  EXPECT_LT(e.rms_mm, 1.2);
  EXPECT_LT(e.worst_mm, 4.0);
}

// Beside the sign's rim the window holds the sign and the wall 1.2 m behind: the lifted point
// is on one of the two surfaces (the one the pixel sees, give or take a pixel), or there is
// none -- never one in between.
TEST(Lift, AtTheRimPicksOneSurfaceOrNone) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::sign_scene();
  const RegisteredDepth r =
      register_depth(test::render_depth(rig, scene, 9), rig.depth_to_color_m, rig.colour);
  // Along a colour ray, the depth of each surface's (unbounded) plane.
  const auto plane_z = [&](const test::Surface& s, const Eigen::Vector2d& px) {
    const Eigen::Vector3d ray = rig.colour.unproject(px);
    const Eigen::Vector3d n = s.u.cross(s.v);
    return n.dot(s.centre) / n.dot(ray);
  };
  int asked = 0, lifted = 0, wrong = 0, other_surface = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      int centre = -1, other = -1;
      truth(rig, scene, Eigen::Vector2d(u, v), &centre);
      truth(rig, scene, Eigen::Vector2d(u + 3, v), &other);
      if (centre == other) continue;  // not at the left or right rim
      for (int du = -3; du <= 3; ++du) {
        const Eigen::Vector2d px(u + du + 0.5, v);
        const auto p = lift(r, px);
        ++asked;
        if (!p) continue;
        ++lifted;
        int seen = -1;
        truth(rig, scene, px, &seen);
        const double on_seen = std::abs(p->z() - plane_z(scene.surfaces[seen], px));
        const double on_other = std::abs(p->z() - plane_z(scene.surfaces[1 - seen], px));
        // A lift from part of a window: a few times the Kinect's noise there.
        const double tolerance = 0.005 + 2.0 * 1.4e-3 * p->z() * p->z();
        if (on_seen > tolerance && on_other > tolerance) {
          ++wrong;
          ADD_FAILURE() << "at " << px.transpose() << ": z " << p->z() << ", " << on_seen
                        << " m off the surface seen, " << on_other << " m off the other";
        }
        if (on_seen > tolerance && on_other <= tolerance) ++other_surface;
      }
    }
  }
  std::printf("rim: %d of %d lifted, %d on the surface beside the one seen, %d in between\n",
              lifted, asked, other_surface, wrong);
  EXPECT_GT(asked, 1000);
  EXPECT_EQ(wrong, 0);
  // Only right at the rim, where the registered image is a pixel or so off.
  EXPECT_LT(other_surface, asked / 20);
}

TEST(Lift, NothingToLift) {
  const test::LightRig rig = test::default_rig();
  DepthFrame empty;
  empty.intrinsics = rig.depth;
  empty.width = 640;
  empty.height = 480;
  empty.depth_mm.assign(640 * 480, 0);
  const RegisteredDepth r = register_depth(empty, rig.depth_to_color_m, rig.colour);
  EXPECT_FALSE(lift(r, Eigen::Vector2d(320, 240)));
  const RegisteredDepth full = register_depth(test::render_depth(rig, test::sign_scene(), 3),
                                              rig.depth_to_color_m, rig.colour);
  EXPECT_TRUE(lift(full, Eigen::Vector2d(320, 240)));
  EXPECT_FALSE(lift(full, Eigen::Vector2d(-3, 240)));
  EXPECT_FALSE(lift(full, Eigen::Vector2d(320, 480.5)));
  empty.depth_mm.pop_back();
  EXPECT_THROW(register_depth(empty, rig.depth_to_color_m, rig.colour), std::invalid_argument);
}

}  // namespace
}  // namespace projtour
