#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/imgproc.hpp>

#include "projtour/contract/geometry.hpp"
#include "projtour/head/projection.hpp"

using namespace projtour;

namespace {

PinholeModel ud_projector(bool distorted) {
  PinholeModel m;
  m.width = 1280;
  m.height = 800;
  m.fx = m.fy = 1920.0;
  m.cx = 640.0;
  m.cy = 400.0;
  // Stronger than a real projector lens so the edges move by pixels.
  if (distorted) m.distortion = {-0.25, 0.12, 0.002, -0.0015, 0.0};
  return m;
}

// A 0.40 x 0.25 m rectangle in the model's y-z plane (front = +x), seen obliquely from 1.2 m.
head::Quad3d model_rectangle() {
  return {Eigen::Vector3d(0.0, 0.20, 0.125), Eigen::Vector3d(0.0, -0.20, 0.125),
          Eigen::Vector3d(0.0, -0.20, -0.125), Eigen::Vector3d(0.0, 0.20, -0.125)};
}

Eigen::Isometry3d T_projector_model_oblique() {
  // Model +x faces the projector (optical -z), turned 25 deg and pitched 10 deg, and off-centre
  // so the quad reaches into the distorted corners of the image.
  Eigen::Isometry3d T_optical_model = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R_face;  // model x -> -z, model y -> -x, model z -> -y
  R_face << 0, -1, 0,      //
      0, 0, -1,            //
      -1, 0, 0;
  T_optical_model.linear() = R_face * Eigen::AngleAxisd(deg_to_rad(25), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(deg_to_rad(10), Eigen::Vector3d::UnitY());
  T_optical_model.translation() = Eigen::Vector3d(0.07, 0.05, 1.2);
  return T_optical_model;
}

// Where the warped content's point `content_px` lands: Newton on the warp's own maps.
Eigen::Vector2d landing_pixel(const head::ContentWarper& w, const Eigen::Vector2d& content_px,
                              Eigen::Vector2d guess) {
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector2d c = w.content_at(guess);
    Eigen::Matrix2d J;
    constexpr double h = 0.5;
    J.col(0) = (w.content_at(guess + Eigen::Vector2d(h, 0)) - c) / h;
    J.col(1) = (w.content_at(guess + Eigen::Vector2d(0, h)) - c) / h;
    const Eigen::Vector2d step = J.inverse() * (content_px - c);
    guess += step;
    if (step.norm() < 1e-6) break;
  }
  return guess;
}

// Max landing error (px) of the content's corners and edge midpoints and centre against where
// the corresponding points of the model rectangle project.
double max_landing_error_px(bool distorted, double* corner_error_px) {
  const PinholeModel projector = ud_projector(distorted);
  const head::Quad3d mp = model_rectangle();
  const Eigen::Isometry3d T = T_projector_model_oblique();
  const head::ProjectedQuad quad = head::project_model_points(mp, T, projector);
  EXPECT_TRUE(quad.on_screen) << quad.problem;
  const cv::Size content_size(800, 500);
  head::ContentWarper warper(projector);
  warper.set_target(content_size, quad);
  const head::Quad2d corners = head::content_corners(content_size);
  double worst_corner = 0.0, worst = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d landed = landing_pixel(warper, corners[i], quad.pixels[i]);
    worst_corner = std::max(worst_corner, (landed - quad.pixels[i]).norm());
  }
  // Interior points: the rectangle is mapped affinely, so content fractions are model fractions.
  for (double fx : {0.5, 0.0, 1.0, 0.25}) {
    for (double fy : {0.0, 0.5, 1.0, 0.75}) {
      const Eigen::Vector3d top = mp[0] + fx * (mp[1] - mp[0]);
      const Eigen::Vector3d bottom = mp[3] + fx * (mp[2] - mp[3]);
      const Eigen::Vector3d p_model = top + fy * (bottom - top);
      const Eigen::Vector2d expected = *projector.project(T * p_model);
      const Eigen::Vector2d content_px(fx * (content_size.width - 1),
                                       fy * (content_size.height - 1));
      const Eigen::Vector2d landed = landing_pixel(warper, content_px, expected);
      worst = std::max(worst, (landed - expected).norm());
    }
  }
  *corner_error_px = worst_corner;
  return std::max(worst, worst_corner);
}

}  // namespace

TEST(Projection, ExactPoseCornersLandOnModelPointsWithinTenthPixel) {
  double corner_px = 0.0;
  const double worst_px = max_landing_error_px(false, &corner_px);
  EXPECT_LT(corner_px, 0.1);
  EXPECT_LT(worst_px, 0.1);
  std::printf("[ figures  ] undistorted: corner error %.4f px, worst over 16 points %.4f px\n",
              corner_px, worst_px);
}

TEST(Projection, DistortedProjectorCornersLandWithinHalfPixel) {
  double corner_px = 0.0;
  const double worst_px = max_landing_error_px(true, &corner_px);
  EXPECT_LT(corner_px, 0.5);
  EXPECT_LT(worst_px, 0.5);
  std::printf("[ figures  ] distorted: corner error %.4f px, worst over 16 points %.4f px\n",
              corner_px, worst_px);
}

TEST(Projection, DistortionMattersAtTheEdges) {
  // A plain homography on the distorted corner pixels misses the edge midpoints by pixels:
  // the test above is not passing by accident.
  const PinholeModel projector = ud_projector(true);
  const head::Quad3d mp = model_rectangle();
  const Eigen::Isometry3d T = T_projector_model_oblique();
  const head::ProjectedQuad quad = head::project_model_points(mp, T, projector);
  const cv::Size content_size(800, 500);
  const cv::Matx33d H = head::homography(head::content_corners(content_size), quad.pixels);
  double worst_px = 0.0;
  for (int i = 0; i < 4; ++i) {  // edge midpoints
    const Eigen::Vector2d c = 0.5 * (head::content_corners(content_size)[i] +
                                     head::content_corners(content_size)[(i + 1) % 4]);
    const cv::Vec3d mid = H * cv::Vec3d(c.x(), c.y(), 1.0);
    const Eigen::Vector2d naive(mid[0] / mid[2], mid[1] / mid[2]);
    const Eigen::Vector2d truth = *projector.project(T * (0.5 * (mp[i] + mp[(i + 1) % 4])));
    worst_px = std::max(worst_px, (naive - truth).norm());
  }
  EXPECT_GT(worst_px, 0.5);
  std::printf("[ figures  ] distorted, homography alone: edge midpoints off by up to %.2f px\n",
              worst_px);
}

TEST(Projection, WarpedImageKeepsCornerOrderAndBlacksOutside) {
  const PinholeModel projector = ud_projector(true);
  const head::ProjectedQuad quad =
      head::project_model_points(model_rectangle(), T_projector_model_oblique(), projector);
  // Quadrants of distinct colours: top-left red, top-right green, bottom-right blue,
  // bottom-left white.
  cv::Mat content(500, 800, CV_8UC3);
  content(cv::Rect(0, 0, 400, 250)).setTo(cv::Scalar(0, 0, 255));
  content(cv::Rect(400, 0, 400, 250)).setTo(cv::Scalar(0, 255, 0));
  content(cv::Rect(400, 250, 400, 250)).setTo(cv::Scalar(255, 0, 0));
  content(cv::Rect(0, 250, 400, 250)).setTo(cv::Scalar(255, 255, 255));
  head::ContentWarper warper(projector);
  const auto t0 = std::chrono::steady_clock::now();
  warper.set_target(content.size(), quad);
  const cv::Mat frame = warper.warp(content);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ figures  ] maps + warp of a 1280x800 frame: %.1f ms\n", ms);
  ASSERT_EQ(frame.size(), cv::Size(1280, 800));
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : quad.pixels) centre += p / 4.0;
  const cv::Vec3b expected[4] = {{0, 0, 255}, {0, 255, 0}, {255, 0, 0}, {255, 255, 255}};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d inside = quad.pixels[i] + 0.15 * (centre - quad.pixels[i]);
    EXPECT_EQ(frame.at<cv::Vec3b>(cvRound(inside.y()), cvRound(inside.x())), expected[i]) << i;
    const Eigen::Vector2d outside = quad.pixels[i] - 0.15 * (centre - quad.pixels[i]);
    EXPECT_EQ(frame.at<cv::Vec3b>(cvRound(outside.y()), cvRound(outside.x())), cv::Vec3b(0, 0, 0))
        << i;
  }
}

// The maps cover only the pixels the content can light: nothing a map over every projector
// pixel would light lies outside the reach, and inside it the frame is that map's (bit for bit
// without distortion, where both take the same ideal pixels; with it, the warp's undistortion
// is interpolated between exact nodes, so within a fraction of a grey level on average).
void expect_reach_warp_is_whole_frame_warp(bool distorted) {
  const PinholeModel projector = ud_projector(distorted);
  Eigen::Isometry3d T = T_projector_model_oblique();
  T.translation().z() = 3.0;  // farther: the content covers a small part of the frame
  const head::ProjectedQuad quad = head::project_model_points(model_rectangle(), T, projector);
  ASSERT_TRUE(quad.on_screen) << quad.problem;
  cv::Mat content(500, 800, CV_8UC3);
  cv::randu(content, cv::Scalar::all(0), cv::Scalar::all(256));
  head::ContentWarper warper(projector);
  warper.set_target(content.size(), quad);
  const cv::Mat frame = warper.warp(content);
  const cv::Rect reach = warper.reach();
  EXPECT_LT(reach.area(), 1280 * 800 / 8) << reach;

  cv::Mat map_x(800, 1280, CV_32F), map_y(800, 1280, CV_32F);
  const cv::Matx33d H_content_ideal = warper.H_ideal_content().inv();
  for (int v = 0; v < 800; ++v) {
    for (int u = 0; u < 1280; ++u) {
      Eigen::Vector2d ideal(u, v);
      if (distorted) {
        const Eigen::Vector3d ray = projector.unproject(ideal);
        ideal = Eigen::Vector2d(projector.fx * ray.x() + projector.cx,
                                projector.fy * ray.y() + projector.cy);
      }
      const cv::Vec3d c = H_content_ideal * cv::Vec3d(ideal.x(), ideal.y(), 1.0);
      map_x.at<float>(v, u) = static_cast<float>(c[0] / c[2]);
      map_y.at<float>(v, u) = static_cast<float>(c[1] / c[2]);
    }
  }
  cv::Mat whole;
  cv::remap(content, whole, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar());
  cv::Mat lit_outside = whole.clone();
  lit_outside(reach).setTo(cv::Scalar::all(0));
  EXPECT_EQ(cv::countNonZero(lit_outside.reshape(1)), 0)
      << "the reach " << reach << " misses lit pixels";
  cv::Mat diff;
  cv::absdiff(frame, whole, diff);
  if (distorted) {
    EXPECT_LT(cv::mean(diff(reach))[0], 0.5);
  } else {
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
  }
}

TEST(Projection, WarpOverTheContentsReachIsTheWholeFramesWarp) {
  expect_reach_warp_is_whole_frame_warp(false);
}

TEST(Projection, WarpOverTheContentsReachIsTheWholeFramesWarpThroughTheLens) {
  expect_reach_warp_is_whole_frame_warp(true);
}

// project keeps its shown frame and warps into it (a fresh 1280x800 frame cost a re-warp 9-11 ms
// of first touch): after the target moves, the kept frame must equal a fresh warp bit for bit, so
// nothing of the old reach stays lit; its buffer is reused; and a copy someone still holds (the
// frame handed to a file writer) keeps the old picture.
TEST(Projection, WarpIntoTheKeptFrameAfterAMoveEqualsAFreshWarpAndSparesAHeldCopy) {
  const PinholeModel projector = ud_projector(true);
  Eigen::Isometry3d T = T_projector_model_oblique();
  T.translation().z() = 3.0;
  cv::Mat content(500, 800, CV_8UC3);
  cv::randu(content, cv::Scalar::all(1), cv::Scalar::all(256));
  head::ContentWarper warper(projector);
  warper.set_target(content.size(), head::project_model_points(model_rectangle(), T, projector));
  cv::Mat kept;
  warper.warp(content, kept);
  const uchar* buffer = kept.data;
  const cv::Mat before = kept.clone();

  T.translation().x() += 0.6;  // far enough that the two reaches do not overlap
  const head::ProjectedQuad moved = head::project_model_points(model_rectangle(), T, projector);
  ASSERT_TRUE(moved.on_screen) << moved.problem;
  const cv::Rect old_reach = warper.reach();
  warper.set_target(content.size(), moved);
  ASSERT_TRUE((old_reach & warper.reach()).empty()) << old_reach << " " << warper.reach();
  warper.warp(content, kept);
  EXPECT_EQ(kept.data, buffer);
  cv::Mat diff;
  cv::absdiff(kept, warper.warp(content), diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
  EXPECT_EQ(cv::countNonZero(kept(old_reach).reshape(1)), 0);

  const cv::Mat held = kept;  // shares the buffer
  const cv::Mat held_pixels = held.clone();
  warper.set_target(content.size(), head::project_model_points(
                                        model_rectangle(), T_projector_model_oblique(), projector));
  warper.warp(content, kept);
  EXPECT_NE(kept.data, held.data);
  cv::absdiff(held, held_pixels, diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
  EXPECT_GT(cv::countNonZero(before.reshape(1)), 0);
}

TEST(Projection, OffScreenAndBehindAreReported) {
  const PinholeModel projector = ud_projector(false);
  Eigen::Isometry3d T = T_projector_model_oblique();
  T.translation().x() += 0.5;  // shifted right past the image edge
  head::ProjectedQuad quad = head::project_model_points(model_rectangle(), T, projector);
  EXPECT_TRUE(quad.in_front);
  EXPECT_FALSE(quad.on_screen);
  EXPECT_NE(quad.problem.find("outside the 1280x800"), std::string::npos) << quad.problem;
  T = T_projector_model_oblique();
  T.translation().z() = 0.05;  // straddles the projector's plane
  quad = head::project_model_points(model_rectangle(), T, projector);
  EXPECT_FALSE(quad.in_front);
  EXPECT_FALSE(quad.on_screen);
  EXPECT_NE(quad.problem.find("behind the projector"), std::string::npos) << quad.problem;
}

TEST(Projection, DegenerateQuadsAreNamed) {
  const head::Quad2d good = {Eigen::Vector2d(100, 100), Eigen::Vector2d(300, 110),
                             Eigen::Vector2d(290, 250), Eigen::Vector2d(105, 240)};
  EXPECT_EQ(head::quad_problem(good), "");
  const head::Quad2d collinear = {Eigen::Vector2d(100, 100), Eigen::Vector2d(200, 100),
                                  Eigen::Vector2d(300, 100), Eigen::Vector2d(400, 100)};
  EXPECT_NE(head::quad_problem(collinear), "");
  const head::Quad2d tiny = {Eigen::Vector2d(100, 100), Eigen::Vector2d(100.5, 100),
                             Eigen::Vector2d(100.5, 100.5), Eigen::Vector2d(100, 100.5)};
  EXPECT_NE(head::quad_problem(tiny).find("zero area"), std::string::npos);
  const head::Quad2d bow_tie = {good[0], good[1], good[3], good[2]};
  EXPECT_EQ(head::quad_problem(bow_tie), "self-crossing");
  const head::Quad2d dented = {good[0], good[1], Eigen::Vector2d(200, 130), good[3]};
  EXPECT_EQ(head::quad_problem(dented), "not convex");
}

TEST(Projection, PlanarityResidual) {
  head::Quad3d square = model_rectangle();
  EXPECT_LT(head::planarity_residual_m(square), 1e-12);
  square[2].x() += 0.010;  // one corner 10 mm out of the plane: the best plane splits it in four
  EXPECT_NEAR(head::planarity_residual_m(square), 0.0025, 1e-4);
}
