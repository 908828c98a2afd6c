#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <memory>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "projtour/views/tour_picture.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

constexpr double kResolutionM = 0.05;

// A 40 x 30 m site, free inside, walled round, with a wall segment inside the toured area.
std::shared_ptr<mrpt::maps::COccupancyGridMap2D> make_site() {
  auto map = std::make_shared<mrpt::maps::COccupancyGridMap2D>(-5.0f, 35.0f, -5.0f, 25.0f,
                                                               static_cast<float>(kResolutionM));
  const int nx = static_cast<int>(map->getSizeX());
  const int ny = static_cast<int>(map->getSizeY());
  for (int cy = 0; cy < ny; ++cy) {
    for (int cx = 0; cx < nx; ++cx) {
      const bool border = cx < 4 || cy < 4 || cx >= nx - 4 || cy >= ny - 4;
      map->setCell(cx, cy, border ? 0.0f : 1.0f);
    }
  }
  // Wall from (2, 3.5) to (6, 3.7) m.
  for (int cx = map->x2idx(2.0); cx <= map->x2idx(6.0); ++cx) {
    for (int cy = map->y2idx(3.5); cy <= map->y2idx(3.7); ++cy) map->setCell(cx, cy, 0.0f);
  }
  return map;
}

std::vector<Pose2D> straight(double x0, double y0, double x1, double y1, int n) {
  std::vector<Pose2D> poses;
  for (int i = 0; i <= n; ++i) {
    const double s = static_cast<double>(i) / n;
    poses.push_back({x0 + s * (x1 - x0), y0 + s * (y1 - y0), 0.0});
  }
  return poses;
}

// The toured area spans x 1..9, y 1..6 m of the 40 x 30 m site.
TourPictureInput make_input() {
  TourPictureInput in;
  in.map = make_site();
  in.title = "test-tour";
  in.start = {1.0, 1.0, 0.0};
  in.targets = {{"top", {8.0, 6.0, kPi}, "projected"},
                {"middle", {9.0, 4.5, kPi / 2}, "skipped"},
                {"bottom", {8.0, 1.0, kPi}, "failed"}};
  in.planned_paths = {straight(1.0, 1.0, 7.0, 1.0, 20), straight(7.0, 1.0, 7.0, 6.0, 20)};
  in.estimated_trajectory = straight(1.0, 2.0, 6.0, 2.0, 50);
  in.true_trajectory = straight(1.0, 2.6, 6.0, 2.6, 50);
  return in;
}

cv::Vec3b bgr(const RgbColour& c) {
  return {c.b, c.g, c.r};
}

struct ColourStats {
  int count = 0;
  double mean_row = 0.0;
};

ColourStats find_colour(const cv::Mat& img, const cv::Vec3b& colour, int rows_limit) {
  ColourStats s;
  for (int r = 0; r < rows_limit; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      if (img.at<cv::Vec3b>(r, c) == colour) {
        ++s.count;
        s.mean_row += r;
      }
    }
  }
  if (s.count > 0) s.mean_row /= s.count;
  return s;
}

TEST(TourPicture, CropsTheMapToTheTourAndScalesItReadably) {
  const TourPictureInput in = make_input();
  const cv::Mat img = render_tour_picture(in);
  ASSERT_EQ(img.type(), CV_8UC3);
  // Tour bbox 8 x 5 m plus a 2 m margin each side: 12 x 9 m = 240 x 180 cells, not the site's
  // 800 x 600; whole pixels per cell, at least 4, long side within 1600 px.
  const int px_per_cell = 1600 / 241 > 16 ? 16 : 1600 / 241;
  EXPECT_GE(px_per_cell, 4);
  EXPECT_NEAR(img.cols, 241 * px_per_cell, 2 * px_per_cell);
  EXPECT_LE(img.cols, 1600);
  EXPECT_GT(img.rows, 181 * px_per_cell);  // the map plus the legend strip below it
  EXPECT_LT(img.rows, 181 * px_per_cell + 200);
}

TEST(TourPicture, DrawsPathsTrajectoriesAndTargetsInTheirColours) {
  const TourPictureInput in = make_input();
  const cv::Mat img = render_tour_picture(in);
  const int map_rows = img.rows - 120;  // stay clear of the legend's own swatches
  EXPECT_GT(find_colour(img, bgr(kPlannedPathColour), map_rows).count, 500);
  EXPECT_GT(find_colour(img, bgr(kEstimatedTrajectoryColour), map_rows).count, 200);
  EXPECT_GT(find_colour(img, bgr(kTrueTrajectoryColour), map_rows).count, 200);
  const ColourStats projected = find_colour(img, bgr(outcome_colour("projected")), map_rows);
  const ColourStats skipped = find_colour(img, bgr(outcome_colour("skipped")), map_rows);
  const ColourStats failed = find_colour(img, bgr(outcome_colour("failed")), map_rows);
  EXPECT_GT(projected.count, 50);
  EXPECT_GT(skipped.count, 50);
  EXPECT_GT(failed.count, 50);
  // y up in the map is up in the picture: top (y 6) above middle (y 4.5) above bottom (y 1).
  EXPECT_LT(projected.mean_row, skipped.mean_row);
  EXPECT_LT(skipped.mean_row, failed.mean_row);
  // The true trajectory (y 2.6) lies above the estimated one (y 2.0).
  EXPECT_LT(find_colour(img, bgr(kTrueTrajectoryColour), map_rows).mean_row,
            find_colour(img, bgr(kEstimatedTrajectoryColour), map_rows).mean_row);
}

TEST(TourPicture, ShowsWallsDarkAndFreeSpaceLight) {
  const TourPictureInput in = make_input();
  const cv::Mat img = render_tour_picture(in);
  // The crop starts 2 m left of x = 1; its top is the edge of the cell 2 m above y = 6.
  const double px_per_m = (img.cols / 241.0) / kResolutionM;
  const auto pixel = [&](double x_m, double y_m) {
    const double x_left = -1.0, y_top = 8.05;
    return img.at<cv::Vec3b>(static_cast<int>((y_top - y_m) * px_per_m),
                             static_cast<int>((x_m - x_left) * px_per_m));
  };
  EXPECT_LT(pixel(4.0, 3.6)[0], 100);   // the wall
  EXPECT_GT(pixel(4.0, 5.0)[0], 240);   // free floor, nothing drawn there
  EXPECT_GT(pixel(-0.5, 7.5)[0], 240);  // free floor in the margin
}

TEST(TourPicture, WithoutATrueTrajectoryItsColourIsAbsent) {
  TourPictureInput in = make_input();
  in.true_trajectory.clear();
  const cv::Mat img = render_tour_picture(in);
  EXPECT_EQ(find_colour(img, bgr(kTrueTrajectoryColour), img.rows).count, 0);
  EXPECT_GT(find_colour(img, bgr(kEstimatedTrajectoryColour), img.rows).count, 200);
}

TEST(TourPicture, LargeSiteKeepsTheLongSideWithin1600Px) {
  TourPictureInput in = make_input();
  in.estimated_trajectory = straight(-4.0, -4.0, 34.0, 24.0, 200);  // the whole 40 x 30 m site
  const cv::Mat img = render_tour_picture(in);
  EXPECT_LE(std::max(img.cols, img.rows - 200), 1600);
  EXPECT_GE(img.cols, 1500);
}

// Regression: in the demo's tall, narrow picture "open-day-sign (projected)" had room on
// neither side of its marker and was drawn off the left edge ("day-sign (projected)").
TEST(TourPicture, ALabelWiderThanEitherSideOfItsMarkerStaysInThePicture) {
  TourPictureInput in = make_input();
  in.start = {5.0, 1.0, kPi / 2};
  in.targets = {{"open-day-sign", {5.2, 20.0, kPi}, "projected"}};
  in.planned_paths = {straight(5.0, 1.0, 5.0, 20.0, 40)};
  in.estimated_trajectory = in.planned_paths[0];
  in.true_trajectory.clear();
  const cv::Mat img = render_tour_picture(in);
  int base = 0;
  const int label_width_px =
      cv::getTextSize("open-day-sign (projected)", cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &base).width;
  ASSERT_LT(img.cols, 2 * label_width_px) << "the picture must be narrow for this test";
  // The label sits above its marker, the topmost thing drawn: its black text is every dark
  // pixel above the marker's green disc. Drawn whole, it spans about its text width.
  int marker_top_row = 0;
  while (marker_top_row < img.rows && find_colour(img.rowRange(marker_top_row, marker_top_row + 1),
                                                  bgr(outcome_colour("projected")), 1)
                                              .count == 0) {
    ++marker_top_row;
  }
  ASSERT_LT(marker_top_row, img.rows / 2);
  int left = img.cols, right = -1;
  for (int r = 0; r + 2 < marker_top_row; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      const cv::Vec3b p = img.at<cv::Vec3b>(r, c);
      if (p[0] < 60 && p[1] < 60 && p[2] < 60) {
        left = std::min(left, c);
        right = std::max(right, c);
      }
    }
  }
  EXPECT_GE(right - left + 1, 0.9 * label_width_px)
      << "label drawn from x " << left << " to " << right;
}

TEST(TourPicture, WritesAPng) {
  const test::TempDir scratch;
  const auto dir = scratch.path();
  const auto png = dir / "run" / "tour.png";
  write_tour_picture(make_input(), png);
  const cv::Mat back = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(back.empty());
  const cv::Mat expected = render_tour_picture(make_input());
  EXPECT_EQ(back.size(), expected.size());
  EXPECT_EQ(cv::norm(back, expected, cv::NORM_INF), 0.0);
}

TEST(SimplifyPolyline, DropsStandingAndStraightSamplesAndKeepsCornersAndTurnarounds) {
  std::vector<Pose2D> trace;
  for (int i = 0; i < 20; ++i) trace.push_back({0.0, 0.0, 0.0});                  // standing
  for (int i = 1; i <= 40; ++i) trace.push_back({0.1 * i, 0.0, 0.0});             // out to 4 m
  for (int i = 1; i <= 20; ++i) trace.push_back({4.0, 0.1 * i, kPi / 2});         // a corner
  for (int i = 1; i <= 20; ++i) trace.push_back({4.0, 2.0 - 0.1 * i, -kPi / 2});  // and back
  trace.push_back({4.0, 0.003, 0.0});  // within the tolerance of the line: dropped
  trace.push_back({3.0, 0.0, kPi});
  const auto kept = simplify_polyline(trace, 0.01);
  ASSERT_EQ(kept.size(), 5u);
  const std::vector<std::pair<double, double>> expected{
      {0.0, 0.0}, {4.0, 0.0}, {4.0, 2.0}, {4.0, 0.0}, {3.0, 0.0}};
  for (std::size_t i = 0; i < kept.size(); ++i) {
    EXPECT_NEAR(kept[i].x_m, expected[i].first, 1e-9) << i;
    EXPECT_NEAR(kept[i].y_m, expected[i].second, 1e-9) << i;
  }
  EXPECT_TRUE(simplify_polyline({}, 0.01).empty());
  EXPECT_EQ(simplify_polyline({{1.0, 2.0, 0.0}}, 0.01).size(), 1u);
}

TEST(TourPicture, RequiresAMap) {
  TourPictureInput in = make_input();
  in.map.reset();
  EXPECT_THROW(render_tour_picture(in), std::invalid_argument);
}

TEST(TourPicture, WriteFailureNamesTheFile) {
  try {
    write_tour_picture(make_input(), "/proc/projtour-no-such-dir/tour.png");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/proc/projtour-no-such-dir/tour.png"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace projtour
