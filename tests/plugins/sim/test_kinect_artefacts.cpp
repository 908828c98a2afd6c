// The Kinect-v1 structured-light artefacts of the noise model: emitter shadows, flying pixels at
// depth edges and spatially correlated noise, on a box in front of a wall with a known answer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>

#include "projtour/contract/geometry.hpp"
#include "projtour/perception/model.hpp"
#include "projtour_sim/depth_renderer.hpp"
#include "projtour_sim/kinect_noise.hpp"
#include "sim_test_scenes.hpp"

namespace projtour::sim {
namespace {

constexpr int kBoxId = 3;
constexpr int kWallId = 7;

// A camera at the origin looking along +x: optical x (image right) is world -y.
const Eigen::Isometry3d kLookX = testing::camera_optical(0, 0, 0, 0, 0);

// A 0.4 m square box, its front face fronto-parallel at near_m, before a 6 m wall at far_m; both
// centred on the optical axis.
Scene box_before_wall(double near_m, double far_m) {
  SceneBuilder builder;
  builder.add_box(Eigen::Isometry3d(Eigen::Translation3d(near_m + 0.1, 0, 0)),
                  Eigen::Vector3d(0.1, 0.2, 0.2), kBoxId);
  builder.add_box(Eigen::Isometry3d(Eigen::Translation3d(far_m + 0.01, 0, 0)),
                  Eigen::Vector3d(0.01, 3.0, 3.0), kWallId);
  return builder.build();
}

Scene wall_only(double far_m) {
  SceneBuilder builder;
  builder.add_box(Eigen::Isometry3d(Eigen::Translation3d(far_m + 0.01, 0, 0)),
                  Eigen::Vector3d(0.01, 3.0, 3.0), kWallId);
  return builder.build();
}

// The same camera at half resolution: the frame's own fx, not the disparity focal length, sets
// the shadow width in its pixels.
PinholeModel half_resolution() {
  PinholeModel k = testing::kinect_intrinsics();
  k.width /= 2;
  k.height /= 2;
  k.fx /= 2;
  k.fy /= 2;
  k.cx = (k.cx + 0.5) / 2 - 0.5;
  k.cy = (k.cy + 0.5) / 2 - 0.5;
  return k;
}

IdealDepth render(const Scene& scene, const PinholeModel& k) {
  IdealDepth ideal;
  DepthRenderer(k).render(scene, kLookX, ideal);
  return ideal;
}

// Missing pixels beside the box, row by row: the runs that start at its left and right edges,
// and any other missing pixel in the frame.
struct MissingBesideBox {
  int rows = 0;  // rows that see the box
  int min_left_px = 1 << 30, max_left_px = 0;
  int min_right_px = 1 << 30, max_right_px = 0;
  int elsewhere = 0;
};

MissingBesideBox missing_beside_box(const IdealDepth& ideal, const DepthFrame& f) {
  MissingBesideBox m;
  int missing = 0, in_runs = 0;
  for (int v = 0; v < f.height; ++v) {
    int first = -1, last = -1;
    for (int u = 0; u < f.width; ++u) {
      missing += f.at(u, v) == 0;
      if (ideal.object_at(u, v) != kBoxId) continue;
      if (first < 0) first = u;
      last = u;
    }
    if (first < 0) continue;
    ++m.rows;
    int left = 0, right = 0;
    while (first - left - 1 >= 0 && f.at(first - left - 1, v) == 0) ++left;
    while (last + right + 1 < f.width && f.at(last + right + 1, v) == 0) ++right;
    m.min_left_px = std::min(m.min_left_px, left);
    m.max_left_px = std::max(m.max_left_px, left);
    m.min_right_px = std::min(m.min_right_px, right);
    m.max_right_px = std::max(m.max_right_px, right);
    in_runs += left + right;
  }
  m.elsewhere = missing - in_runs;
  return m;
}

TEST(KinectArtefacts, ShadowBandOnTheSideAwayFromTheEmitterWithThePredictedWidth) {
  struct Case {
    PinholeModel k;
    double near_m, far_m;
  };
  const Case cases[] = {{testing::kinect_intrinsics(), 1.0, 2.5},
                        {testing::kinect_intrinsics(), 1.5, 3.5},
                        {half_resolution(), 1.0, 2.5}};
  for (const Case& c : cases) {
    const IdealDepth ideal = render(box_before_wall(c.near_m, c.far_m), c.k);
    KinectNoiseParams p;
    const double band_px = c.k.fx * p.baseline_m * (1.0 / c.near_m - 1.0 / c.far_m);
    for (int side : {+1, -1}) {
      SCOPED_TRACE(::testing::Message()
                   << "fx " << c.k.fx << ", box at " << c.near_m << " m, wall at " << c.far_m
                   << " m, emitter side " << side << ", predicted band " << band_px << " px");
      p.shadows = true;
      p.emitter_side = side;
      std::mt19937_64 rng(3);
      const DepthFrame shadowed = apply_kinect_noise(ideal, c.k, p, rng);
      const MissingBesideBox m = missing_beside_box(ideal, shadowed);
      ASSERT_GT(m.rows, 0.25 * c.k.height);
      // The emitter at +x lights the box's right side: the shadow falls on its left.
      const int far_min = side > 0 ? m.min_left_px : m.min_right_px;
      const int far_max = side > 0 ? m.max_left_px : m.max_right_px;
      const int near_max = side > 0 ? m.max_right_px : m.max_left_px;
      EXPECT_GE(far_min, band_px - 1.0);
      EXPECT_LE(far_max, band_px + 1.0);
      EXPECT_EQ(near_max, 0);
      EXPECT_EQ(m.elsewhere, 0);

      // Same seed, shadows off: nothing missing, and every reading the shadowed frame kept is
      // the same (a shadowed pixel still draws).
      p.shadows = false;
      rng.seed(3);
      const DepthFrame lit = apply_kinect_noise(ideal, c.k, p, rng);
      const MissingBesideBox none = missing_beside_box(ideal, lit);
      EXPECT_EQ(none.max_left_px + none.max_right_px + none.elsewhere, 0);
      int blanked = 0, changed = 0;
      for (std::size_t i = 0; i < lit.depth_mm.size(); ++i) {
        blanked += shadowed.depth_mm[i] == 0;
        changed += shadowed.depth_mm[i] != 0 && shadowed.depth_mm[i] != lit.depth_mm[i];
      }
      EXPECT_EQ(changed, 0);
      EXPECT_NEAR(blanked, band_px * m.rows, 1.0 * m.rows);
    }
  }
}

// A surface is in its own shadow once it turns its back on the emitter while the camera still
// sees its front: within atan(b / z) (2.1 deg at 2 m) of edge-on, on the emitter's side only.
TEST(KinectArtefacts, SurfaceTurnedAwayFromTheEmitterShadowsItself) {
  const PinholeModel k = testing::kinect_intrinsics();
  KinectNoiseParams p;
  p.max_incidence_deg = 90.0;  // keep the grazing pixels, which the shadow test is about
  // Readings with shadows over readings without, same seed.
  auto lit_fraction = [&](double yaw_deg) {
    SceneBuilder builder;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() =
        Eigen::AngleAxisd(deg_to_rad(yaw_deg), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(2.0, 0, 0);
    builder.add_box(T, Eigen::Vector3d(0.01, 3.0, 3.0), kWallId);
    const IdealDepth ideal = render(builder.build(), k);
    std::mt19937_64 rng(1);
    p.shadows = false;
    const std::size_t plain = apply_kinect_noise(ideal, k, p, rng).valid_count();
    rng.seed(1);
    p.shadows = true;
    const std::size_t shadowed = apply_kinect_noise(ideal, k, p, rng).valid_count();
    EXPECT_GT(plain, 1000u) << "at " << yaw_deg << " deg";
    return static_cast<double>(shadowed) / static_cast<double>(plain);
  };
  // Positive yaw turns the wall's face towards world -y, which is image right, the emitter's
  // side: lit however steep. Negative yaw turns it away: lit at 80 deg, dark at 89.5.
  EXPECT_EQ(lit_fraction(80.0), 1.0);
  EXPECT_EQ(lit_fraction(89.5), 1.0);
  EXPECT_EQ(lit_fraction(-80.0), 1.0);
  EXPECT_EQ(lit_fraction(-89.5), 0.0);
}

bool on_depth_edge(const IdealDepth& ideal, int u, int v, double min_jump_m) {
  const float z = ideal.depth_at(u, v);
  const int du[] = {-1, 1, 0, 0}, dv[] = {0, 0, -1, 1};
  for (int n = 0; n < 4; ++n) {
    const int un = u + du[n], vn = v + dv[n];
    if (un < 0 || vn < 0 || un >= ideal.width || vn >= ideal.height) continue;
    const float zn = ideal.depth_at(un, vn);
    if (zn > 0.0f && std::abs(zn - z) > min_jump_m) return true;
  }
  return false;
}

TEST(KinectArtefacts, FlyingPixelsOnlyAtEdgesAndBetweenTheTwoDepths) {
  const PinholeModel k = testing::kinect_intrinsics();
  const double near_m = 1.0, far_m = 2.5;
  const IdealDepth ideal = render(box_before_wall(near_m, far_m), k);
  // Without noise or quantisation a reading is the ideal depth unless it flew.
  KinectNoiseParams p;
  p.axial_noise = false;
  p.quantise = false;
  std::mt19937_64 rng(11);
  const DepthFrame still = apply_kinect_noise(ideal, k, p, rng);
  p.flying_pixels = true;
  const DepthFrame flying = apply_kinect_noise(ideal, k, p, rng);
  int edge_pixels = 0, flown = 0, off_edge = 0, outside = 0;
  double disparity_sum = 0.0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const bool edge = on_depth_edge(ideal, u, v, p.flying_pixel_min_jump_m);
      edge_pixels += edge;
      const std::uint16_t mm = flying.at(u, v);
      if (mm == still.at(u, v)) continue;
      ++flown;
      off_edge += !edge;
      outside += mm < near_m * 1000 || mm > far_m * 1000;
      disparity_sum += 1000.0 / mm;
    }
  }
  // Both sides of the box's outline: 0.4 m at 1 m and fx 570 is a 228 px square.
  EXPECT_NEAR(edge_pixels, 2 * 4 * 228, 16);
  EXPECT_EQ(off_edge, 0);
  EXPECT_EQ(outside, 0);
  EXPECT_NEAR(static_cast<double>(flown) / edge_pixels, p.flying_pixel_probability, 0.05);
  // Mixed in disparity, uniformly: the mean 1/z is halfway between 1/near and 1/far (a depth
  // mix would put it at 0.6 1/m, not 0.7).
  EXPECT_NEAR(disparity_sum / flown, 0.5 * (1.0 / near_m + 1.0 / far_m), 0.02);

  // All of them: every edge pixel flies (the rare one that lands within 0.5 mm of its own depth
  // rounds back to it).
  p.flying_pixel_probability = 1.0;
  const DepthFrame all = apply_kinect_noise(ideal, k, p, rng);
  int all_flown = 0;
  for (std::size_t i = 0; i < all.depth_mm.size(); ++i) {
    all_flown += all.depth_mm[i] != still.depth_mm[i];
  }
  EXPECT_GE(all_flown, edge_pixels - 5);
  EXPECT_LE(all_flown, edge_pixels);
}

// Beside the emitter's shadow the correlation window sees no speckle on the far side of the
// edge, so the box's edge pixels there hold their depth; on the lit side they fly.
TEST(KinectArtefacts, NoFlyingPixelsIntoTheShadow) {
  const PinholeModel k = testing::kinect_intrinsics();
  const IdealDepth ideal = render(box_before_wall(1.0, 2.5), k);
  KinectNoiseParams p;
  p.axial_noise = false;
  p.quantise = false;
  p.shadows = true;
  p.flying_pixels = true;
  p.flying_pixel_probability = 1.0;
  std::mt19937_64 rng(2);
  const DepthFrame f = apply_kinect_noise(ideal, k, p, rng);
  int rows = 0, left_flown = 0, right_flown = 0;
  for (int v = 0; v < k.height; ++v) {
    int first = -1, last = -1;
    for (int u = 0; u < k.width; ++u) {
      if (ideal.object_at(u, v) != kBoxId) continue;
      if (first < 0) first = u;
      last = u;
    }
    // Rows clear of the top and bottom faces, where the vertical edge is the only one.
    if (first < 0 || v == 0 || v + 1 == k.height || ideal.object_at(first, v - 1) != kBoxId ||
        ideal.object_at(first, v + 1) != kBoxId) {
      continue;
    }
    ++rows;
    left_flown += f.at(first, v) != 1000;
    right_flown += f.at(last, v) != 1000;
  }
  ASSERT_GT(rows, 200);
  EXPECT_EQ(left_flown, 0);
  EXPECT_GE(right_flown, rows - 2);
}

// Residual statistics of frames of a fronto-parallel wall at distance_m.
struct NoiseStats {
  double sigma_m = 0.0;
  double correlation_at_1px = 0.0;
  double correlation_at_20px = 0.0;
  double correlated_sigma_m = 0.0;  // from the 1 px covariance of a 9 px box: cov = 8/9 var
};

NoiseStats wall_noise(double distance_m, const KinectNoiseParams& p) {
  const PinholeModel k = testing::kinect_intrinsics();
  const IdealDepth ideal = render(wall_only(distance_m), k);
  std::mt19937_64 rng(21);
  double sum = 0, sum2 = 0, lag1 = 0, lag20 = 0;
  long n = 0, n1 = 0, n20 = 0, missing = 0;
  for (int frame = 0; frame < 4; ++frame) {
    const DepthFrame f = apply_kinect_noise(ideal, k, p, rng);
    auto e = [&](int u, int v) { return f.at(u, v) * 1e-3 - distance_m; };
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) {
        missing += f.at(u, v) == 0;
        const double eu = e(u, v);
        sum += eu;
        sum2 += eu * eu;
        ++n;
        // Horizontal and vertical neighbours alike.
        if (u + 1 < k.width && v + 1 < k.height) {
          lag1 += eu * (e(u + 1, v) + e(u, v + 1));
          n1 += 2;
        }
        if (u + 20 < k.width && v + 20 < k.height) {
          lag20 += eu * (e(u + 20, v) + e(u, v + 20));
          n20 += 2;
        }
      }
    }
  }
  EXPECT_EQ(missing, 0);
  const double mean = sum / n;
  const double var = sum2 / n - mean * mean;
  NoiseStats s;
  s.sigma_m = std::sqrt(var);
  const double cov1 = lag1 / n1 - mean * mean;
  s.correlation_at_1px = cov1 / var;
  s.correlation_at_20px = (lag20 / n20 - mean * mean) / var;
  const double w = p.correlation_window_px;
  s.correlated_sigma_m = std::sqrt(std::max(cov1, 0.0) * w / (w - 1));
  return s;
}

TEST(KinectArtefacts, CorrelatedNoiseKeepsTheSigmaAndCorrelatesOverTheWindow) {
  KinectNoiseParams p;
  p.quantise = false;  // quantisation would add its own, pixel-wise, error
  for (double z : {2.0, 3.0}) {
    const double sigma = kinect_axial_sigma_m(z);
    p.correlated_noise = false;
    const NoiseStats white = wall_noise(z, p);
    EXPECT_NEAR(white.sigma_m, sigma, 0.03 * sigma) << "at " << z << " m";
    EXPECT_NEAR(white.correlation_at_1px, 0.0, 0.01) << "at " << z << " m";
    p.correlated_noise = true;
    for (double fraction : {0.5, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "fraction " << fraction << " at " << z << " m");
      p.correlated_noise_fraction = fraction;
      const NoiseStats s = wall_noise(z, p);
      // The total stays the published sigma; the correlated part has the documented share.
      EXPECT_NEAR(s.sigma_m, sigma, 0.03 * sigma);
      EXPECT_NEAR(s.correlated_sigma_m, fraction * sigma, 0.03 * fraction * sigma);
      EXPECT_NEAR(s.correlation_at_1px, fraction * fraction * 8.0 / 9.0, 0.02);
      EXPECT_NEAR(s.correlation_at_20px, 0.0, 0.03);
    }
  }
  // As it runs, quantised: the white part still has room for the quantisation variance, and the
  // total is the published sigma as closely as without the correlated part (AxialSigmaMatches).
  p.quantise = true;
  p.correlated_noise_fraction = 0.5;
  for (double z : {1.0, 2.0, 3.0}) {
    const double sigma = kinect_axial_sigma_m(z);
    EXPECT_NEAR(wall_noise(z, p).sigma_m, sigma, 0.1 * sigma) << "at " << z << " m";
  }
}

std::uint64_t fnv1a(const std::vector<std::uint16_t>& mm) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::uint16_t x : mm) {
    for (int b = 0; b < 2; ++b) {
      h ^= (x >> (8 * b)) & 0xFF;
      h *= 1099511628211ull;
    }
  }
  return h;
}

// With every artefact off the frames are those of the model before the artefacts, draw for draw:
// the hashes of two consecutive frames and the engine's next output, as the code before them
// gave (GCC, x86-64), whatever the artefacts' own parameters say.
TEST(KinectArtefacts, OffGivesTheFramesOfTheModelWithoutThem) {
  const PinholeModel k = testing::kinect_intrinsics();
  SceneBuilder builder;
  builder.add_mesh(
      perception::load_mesh(std::string(PROJTOUR_SOURCE_DIR) + "/examples/models/bunny.ply"),
      isometry_from_xyz_rpy(1.2, 0, 0, 0, 0, kPi), 2);
  builder.add_occupancy_walls(*testing::room_grid(-1.0f, 2.5f, -2.0f, 2.0f), 2.0, 1);
  builder.set_floor(-0.9, 0);
  const IdealDepth ideal = render(builder.build(), k);
  KinectNoiseParams off;
  off.emitter_side = -1;
  off.flying_pixel_probability = 1.0;
  off.flying_pixel_min_jump_m = 0.01;
  off.correlated_noise_fraction = 1.0;
  off.correlation_window_px = 3;
  for (const KinectNoiseParams& p : {KinectNoiseParams{}, off}) {
    std::mt19937_64 rng(5);
    const DepthFrame first = apply_kinect_noise(ideal, k, p, rng);
    const DepthFrame second = apply_kinect_noise(ideal, k, p, rng);
    EXPECT_EQ(first.valid_count(), 208435u);
    EXPECT_EQ(fnv1a(first.depth_mm), 9002247123567959512ull);
    EXPECT_EQ(fnv1a(second.depth_mm), 5757913872836141616ull);
    EXPECT_EQ(rng(), 16389199262659801072ull);
  }
}

TEST(KinectArtefacts, SeededAndDrawnOnlyFromTheEngine) {
  const PinholeModel k = testing::kinect_intrinsics();
  const IdealDepth ideal = render(box_before_wall(1.0, 2.5), k);
  KinectNoiseParams p;
  p.shadows = p.flying_pixels = p.correlated_noise = true;
  std::mt19937_64 a(8), b(8), c(9);
  const DepthFrame fa = apply_kinect_noise(ideal, k, p, a);
  const DepthFrame fb = apply_kinect_noise(ideal, k, p, b);
  const DepthFrame fc = apply_kinect_noise(ideal, k, p, c);
  EXPECT_GT(fa.valid_count(), 250000u);
  EXPECT_EQ(fa.depth_mm, fb.depth_mm);
  EXPECT_NE(fa.depth_mm, fc.depth_mm);
  EXPECT_EQ(a(), b());
}

TEST(KinectArtefacts, BadParametersOfAnArtefactThatIsOnAreRefused) {
  const PinholeModel k = testing::kinect_intrinsics();
  const IdealDepth ideal = render(wall_only(2.0), k);
  std::mt19937_64 rng(1);
  KinectNoiseParams p;
  p.emitter_side = 0;
  p.flying_pixel_probability = 1.5;
  p.correlated_noise_fraction = -0.1;
  EXPECT_NO_THROW(apply_kinect_noise(ideal, k, p, rng));
  p.shadows = true;
  EXPECT_THROW(apply_kinect_noise(ideal, k, p, rng), std::invalid_argument);
  p.shadows = false;
  p.flying_pixels = true;
  EXPECT_THROW(apply_kinect_noise(ideal, k, p, rng), std::invalid_argument);
  p.flying_pixels = false;
  p.correlated_noise = true;
  EXPECT_THROW(apply_kinect_noise(ideal, k, p, rng), std::invalid_argument);
  p.correlated_noise_fraction = 0.5;
  p.correlation_window_px = 0;
  EXPECT_THROW(apply_kinect_noise(ideal, k, p, rng), std::invalid_argument);
  p.correlated_noise = false;
  p.flying_pixels = true;
  p.flying_pixel_probability = 0.5;
  p.flying_pixel_min_jump_m = 0.0;
  EXPECT_THROW(apply_kinect_noise(ideal, k, p, rng), std::invalid_argument);
}

}  // namespace
}  // namespace projtour::sim
