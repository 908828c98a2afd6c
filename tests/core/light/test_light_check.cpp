// The verify step's checks on the rendered sign: the four dots found where the projector put
// them, the model's depth in the colour image, and the share of the light an occluder catches.
#include <gtest/gtest.h>

#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>

#include "light_scene.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/light/light_check.hpp"

namespace projtour {
namespace {

using light::dots_frame;
using light::find_dots;
using light::light_on_target;
using light::LightOnTarget;
using light::model_depth;

cv::Mat black(const PinholeModel& projector) {
  return cv::Mat::zeros(projector.height, projector.width, CV_8UC3);
}

TEST(DotsFrame, DiscsCentredOnTheirPixels) {
  const PinholeModel p = test::default_rig().projector;
  const std::array<Eigen::Vector2d, 4> at = {
      Eigen::Vector2d(300.3, 200.7), {900.5, 210.0}, {320.0, 610.25}, {1270.0, 790.0}};
  const cv::Mat frame = dots_frame(p, at, 10);
  ASSERT_EQ(frame.type(), CV_8UC3);
  ASSERT_EQ(frame.size(), cv::Size(1280, 800));
  cv::Mat grey;
  cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  for (std::size_t i = 0; i < 3; ++i) {
    const cv::Rect box(static_cast<int>(at[i].x()) - 15, static_cast<int>(at[i].y()) - 15, 31, 31);
    const cv::Moments m = cv::moments(grey(box));
    const Eigen::Vector2d centroid(box.x + m.m10 / m.m00, box.y + m.m01 / m.m00);
    EXPECT_LT((centroid - at[i]).norm(), 0.01) << i;
    EXPECT_NEAR(m.m00 / 255.0, kPi * 100.0, 2.0) << i;  // the disc's area
  }
  // The one at the corner is cut by the frame's edge; nothing else is lit.
  EXPECT_GT(grey.at<std::uint8_t>(795, 1275), 0);
  EXPECT_EQ(grey.at<std::uint8_t>(400, 640), 0);
}

// The rendered sign with four dots on it, 6 cm in from its corners.
struct DotScene {
  test::LightRig rig = test::default_rig();
  test::Scene scene = test::sign_scene();
  std::unique_ptr<test::ColourRenderer> renderer;
  std::array<Eigen::Vector2d, 4> projector_px;
  std::array<Eigen::Vector2d, 4> truth_colour_px;
};

DotScene dot_scene(test::Scene scene) {
  DotScene s;
  s.scene = std::move(scene);
  s.renderer = std::make_unique<test::ColourRenderer>(s.rig, s.scene);
  const test::Surface& sign = s.scene.surfaces[0];
  int i = 0;
  for (double a : {-1.0, 1.0}) {
    for (double b : {-1.0, 1.0}) {
      const Eigen::Vector3d p =
          sign.centre + a * (sign.half_u_m - 0.06) * sign.u + b * (sign.half_v_m - 0.06) * sign.v;
      s.projector_px[static_cast<std::size_t>(i)] =
          *s.rig.projector.project(s.rig.T_projector_camera() * p);
      ++i;
    }
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const auto seen = s.renderer->colour_px_of(s.projector_px[k]);
    s.truth_colour_px[k] = seen ? *seen : Eigen::Vector2d(-1, -1);
  }
  return s;
}

TEST(FindDots, LocatesTheDotsToAFractionOfAPixel) {
  const DotScene s = dot_scene(test::sign_scene());
  const ColourFrame dark = s.renderer->render(black(s.rig.projector), 1);
  const ColourFrame lit = s.renderer->render(dots_frame(s.rig.projector, s.projector_px, 12), 2);
  // Expected where a calibration 1 cm off would put them: some pixels away.
  std::array<Eigen::Vector2d, 4> expected = s.truth_colour_px;
  for (Eigen::Vector2d& e : expected) e += Eigen::Vector2d(4.0, -3.0);
  const auto found = find_dots(dark, lit, expected, 20.0);
  for (std::size_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(found[i]) << "dot " << i;
    const double error = (*found[i] - s.truth_colour_px[i]).norm();
    std::printf("dot %zu at %.2f %.2f: %.3f colour px off\n", i, s.truth_colour_px[i].x(),
                s.truth_colour_px[i].y(), error);
    EXPECT_LT(error, 0.3) << "dot " << i;
  }
}

TEST(FindDots, MissingDots) {
  test::Scene scene = test::sign_scene();
  const DotScene s = dot_scene(scene);
  std::array<Eigen::Vector2d, 4> shown = s.projector_px;
  shown[1] = Eigen::Vector2d(-200.0, -200.0);  // off the projector: not shown at all
  const ColourFrame dark = s.renderer->render(black(s.rig.projector), 3);
  const ColourFrame lit = s.renderer->render(dots_frame(s.rig.projector, shown, 12), 4);
  std::array<Eigen::Vector2d, 4> expected = s.truth_colour_px;
  expected[2] += Eigen::Vector2d(60.0, 0.0);  // looked for far from where it is
  const auto found = find_dots(dark, lit, expected, 20.0);
  EXPECT_TRUE(found[0]);
  EXPECT_FALSE(found[1]);
  EXPECT_FALSE(found[2]);
  EXPECT_TRUE(found[3]);
  // The same frame twice: no light added anywhere.
  for (const auto& f : find_dots(dark, dark, s.truth_colour_px, 20.0)) EXPECT_FALSE(f);
  ColourFrame small = dark;
  small.width = 320;
  EXPECT_THROW(find_dots(small, lit, expected, 20.0), std::invalid_argument);
}

TEST(ModelDepth, TheSignModelWhereTheCameraSeesTheSign) {
  const test::LightRig rig = test::default_rig();
  const test::Scene scene = test::sign_scene();
  Eigen::Isometry3d T_camera_model;
  ModelCloud model = test::rectangle_model(scene.surfaces[0], 0.003, T_camera_model);
  const std::vector<float> depth = model_depth(model, T_camera_model, rig.colour);
  ASSERT_EQ(depth.size(), 640u * 480u);
  // The truth, and two pixels' slack at the rim for the splat and the samples' spacing.
  cv::Mat on_sign = cv::Mat::zeros(480, 640, CV_8U);
  cv::Mat truth_z = cv::Mat::zeros(480, 640, CV_32F);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d ray = rig.colour.unproject(Eigen::Vector2d(u, v)).normalized();
      const auto hit = scene.intersect(Eigen::Vector3d::Zero(), ray);
      if (!hit || hit->surface != 0) continue;
      on_sign.at<std::uint8_t>(v, u) = 255;
      truth_z.at<float>(v, u) = static_cast<float>(hit->t * ray.z());
    }
  }
  cv::Mat inner, outer;
  const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5));
  cv::erode(on_sign, inner, square);
  cv::dilate(on_sign, outer, square);
  int inside = 0, covered = 0, outside_lit = 0;
  double worst_mm = 0.0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const float z = depth[static_cast<std::size_t>(v) * 640 + u];
      if (inner.at<std::uint8_t>(v, u)) {
        ++inside;
        if (z == 0.0f) continue;
        ++covered;
        worst_mm = std::max(worst_mm, 1000.0 * std::abs(z - truth_z.at<float>(v, u)));
      } else if (!outer.at<std::uint8_t>(v, u)) {
        outside_lit += z != 0.0f;
      }
    }
  }
  std::printf("model depth: %d of %d sign pixels, worst %.2f mm, %d pixels beside it\n", covered,
              inside, worst_mm, outside_lit);
  EXPECT_GT(inside, 15000);
  EXPECT_EQ(covered, inside);
  EXPECT_EQ(outside_lit, 0);
  EXPECT_LT(worst_mm, 1.5);

  // Its back face, 2 cm behind and facing away, does not show through.
  const std::size_t front = model.points.size();
  for (std::size_t i = 0; i < front; ++i) {
    model.points.push_back(model.points[i] + Eigen::Vector3f(0.0f, 0.0f, 0.02f));
    model.normals.emplace_back(0.0f, 0.0f, 1.0f);
  }
  EXPECT_EQ(model_depth(model, T_camera_model, rig.colour), depth);
}

// The content lights the sign (the projector pixels that reach it with nothing in the way); a
// pole between the projector and the sign catches part of that light.
struct OcclusionCase {
  LightOnTarget measured;
  double truth_in_front = 0.0, truth_on_target = 0.0;
};

OcclusionCase occlusion(bool with_pole) {
  const test::LightRig rig = test::default_rig();
  const test::Scene clear = test::sign_scene();
  test::Scene scene = clear;
  if (with_pole) test::add_pole(scene, 0.03, 0.9);
  const test::ColourRenderer renderer(rig, scene);
  cv::Mat content = black(rig.projector);
  content.setTo(cv::Scalar::all(255), test::projector_mask(rig, clear, 0));
  const ColourFrame dark = renderer.render(black(rig.projector), 5);
  const ColourFrame lit = renderer.render(content, 6);
  const light::RegisteredDepth depth =
      light::register_depth(test::render_depth(rig, scene, 7), rig.depth_to_color_m, rig.colour);
  Eigen::Isometry3d T_camera_model;
  const ModelCloud model = test::rectangle_model(clear.surfaces[0], 0.003, T_camera_model);
  OcclusionCase c;
  c.measured = light_on_target(dark, lit, depth, model_depth(model, T_camera_model, rig.colour));

  // The truth: the added light by the surface each pixel sees.
  cv::Mat dark_grey, lit_grey;
  cv::cvtColor(cv::Mat(480, 640, CV_8UC3, const_cast<std::uint8_t*>(dark.bgr.data())), dark_grey,
               cv::COLOR_BGR2GRAY);
  cv::cvtColor(cv::Mat(480, 640, CV_8UC3, const_cast<std::uint8_t*>(lit.bgr.data())), lit_grey,
               cv::COLOR_BGR2GRAY);
  double total = 0.0, on_pole = 0.0, on_sign = 0.0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const int added = lit_grey.at<std::uint8_t>(v, u) - dark_grey.at<std::uint8_t>(v, u);
      if (added <= 20) continue;
      total += added;
      const int surface = renderer.surface_at(u, v);
      if (surface == 0) on_sign += added;
      if (with_pole && surface == 1) on_pole += added;
    }
  }
  c.truth_in_front = on_pole / total;
  c.truth_on_target = on_sign / total;
  std::printf("%s: %d lit pixels, on the target %.4f (truth %.4f), in front %.4f (truth %.4f)\n",
              with_pole ? "pole" : "clear", c.measured.lit_pixels, c.measured.on_target_fraction,
              c.truth_on_target, c.measured.in_front_fraction, c.truth_in_front);
  return c;
}

TEST(LightOnTarget, AnOccluderCatchesItsShare) {
  const OcclusionCase c = occlusion(true);
  EXPECT_GT(c.truth_in_front, 0.05);  // the pole is really in the way
  EXPECT_NEAR(c.measured.in_front_fraction, c.truth_in_front, 0.01);
  EXPECT_NEAR(c.measured.on_target_fraction, c.truth_on_target, 0.02);
  EXPECT_LE(c.measured.on_target_fraction + c.measured.in_front_fraction, 1.0 + 1e-12);
}

TEST(LightOnTarget, ClearViewIsAllOnTheTarget) {
  const OcclusionCase c = occlusion(false);
  EXPECT_GT(c.measured.lit_pixels, 15000);
  EXPECT_LT(c.measured.in_front_fraction, 0.002);
  EXPECT_GT(c.measured.on_target_fraction, 0.98);
  EXPECT_NEAR(c.measured.on_target_fraction, c.truth_on_target, 0.02);
}

TEST(LightOnTarget, GreyLevelsAreOpenCvs) {
  // Random colours over black: the pixels counted lit are those cvtColor's grey puts above the
  // level, so the threshold means the same here as in decode().
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> level(0, 255);
  const PinholeModel colour = test::default_rig().colour;
  ColourFrame dark, lit;
  dark.width = lit.width = colour.width;
  dark.height = lit.height = colour.height;
  dark.bgr.assign(640 * 480 * 3, 0);
  lit.bgr.resize(dark.bgr.size());
  for (std::uint8_t& b : lit.bgr) b = static_cast<std::uint8_t>(level(rng));
  light::RegisteredDepth depth;
  depth.colour = colour;
  depth.z_m.assign(640 * 480, 0.0f);
  cv::Mat grey;
  cv::cvtColor(cv::Mat(480, 640, CV_8UC3, lit.bgr.data()), grey, cv::COLOR_BGR2GRAY);
  for (int threshold : {20, 100, 200}) {
    const LightOnTarget r =
        light_on_target(dark, lit, depth, std::vector<float>(640 * 480, 0.0f), 0.03, threshold);
    EXPECT_EQ(r.lit_pixels, cv::countNonZero(grey > threshold)) << threshold;
    EXPECT_EQ(r.on_target_fraction, 0.0);  // no depth: nothing shown to be on the target
  }
  const LightOnTarget none =
      light_on_target(dark, dark, depth, std::vector<float>(640 * 480, 0.0f));
  EXPECT_EQ(none.lit_pixels, 0);
  EXPECT_EQ(none.on_target_fraction, 0.0);
  EXPECT_THROW(light_on_target(dark, lit, depth, std::vector<float>(10, 0.0f)),
               std::invalid_argument);
}

}  // namespace
}  // namespace projtour
