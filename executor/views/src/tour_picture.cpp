#include "projtour/views/tour_picture.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "projtour/contract/run_image.hpp"

namespace projtour {

namespace {

constexpr double kMarginM = 2.0;  // room around the toured area for markers and labels
constexpr double kMaxLongSidePx = 1600.0;
constexpr double kMaxPxPerCell = 16.0;  // a tiny tour is not blown up beyond readability
constexpr int kMinCanvasWidthPx = 360;  // the legend needs this much even for a narrow crop
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kShift = 3;  // sub-pixel bits for cv drawing, so thin lines stay smooth
constexpr double kSubPixel = 1 << kShift;

cv::Scalar bgr(const RgbColour& c) {
  return cv::Scalar(c.b, c.g, c.r);
}

// The cropped window of the grid and how it maps to pixels.
struct View {
  int cx0 = 0, cy0 = 0, cx1 = 0, cy1 = 0;  // cell range, end exclusive
  double x_left_m = 0.0, y_top_m = 0.0, px_per_m = 1.0;
  int width_px = 0, height_px = 0;

  cv::Point2d to_px(double x_m, double y_m) const {
    return {(x_m - x_left_m) * px_per_m, (y_top_m - y_m) * px_per_m};
  }
  cv::Point fixed(double x_m, double y_m) const {
    const cv::Point2d p = to_px(x_m, y_m);
    return {static_cast<int>(std::lround(p.x * kSubPixel)),
            static_cast<int>(std::lround(p.y * kSubPixel))};
  }
};

View make_view(const TourPictureInput& in) {
  const auto& map = *in.map;
  const double res = map.getResolution();
  double x_min = in.start.x_m, x_max = in.start.x_m;
  double y_min = in.start.y_m, y_max = in.start.y_m;
  const auto grow = [&](const Pose2D& p) {
    x_min = std::min(x_min, p.x_m);
    x_max = std::max(x_max, p.x_m);
    y_min = std::min(y_min, p.y_m);
    y_max = std::max(y_max, p.y_m);
  };
  for (const auto& t : in.targets) grow(t.pose);
  for (const auto& path : in.planned_paths) std::for_each(path.begin(), path.end(), grow);
  std::for_each(in.estimated_trajectory.begin(), in.estimated_trajectory.end(), grow);
  std::for_each(in.true_trajectory.begin(), in.true_trajectory.end(), grow);

  // The crop may reach past the map's edge (a target near it still gets its margin) but no
  // further than the margin, so a wild trajectory point cannot blow the picture up.
  const int size_x = static_cast<int>(map.getSizeX());
  const int size_y = static_cast<int>(map.getSizeY());
  const int margin_cells = static_cast<int>(std::ceil(kMarginM / res));
  const auto cell_x = [&](double x) {
    return std::clamp(static_cast<int>(std::floor((x - map.getXMin()) / res)), -margin_cells,
                      size_x + margin_cells);
  };
  const auto cell_y = [&](double y) {
    return std::clamp(static_cast<int>(std::floor((y - map.getYMin()) / res)), -margin_cells,
                      size_y + margin_cells);
  };
  View v;
  v.cx0 = cell_x(x_min - kMarginM);
  v.cx1 = cell_x(x_max + kMarginM) + 1;
  v.cy0 = cell_y(y_min - kMarginM);
  v.cy1 = cell_y(y_max + kMarginM) + 1;
  const int long_cells = std::max(v.cx1 - v.cx0, v.cy1 - v.cy0);
  double px_per_cell = std::min(kMaxPxPerCell, kMaxLongSidePx / long_cells);
  // Whole pixels per cell keep the cells crisp; large sites get a fractional scale instead.
  if (px_per_cell >= 2.0) px_per_cell = std::floor(px_per_cell);
  v.px_per_m = px_per_cell / res;
  v.x_left_m = map.getXMin() + v.cx0 * res;
  v.y_top_m = map.getYMin() + v.cy1 * res;
  v.width_px = std::max(1, static_cast<int>(std::lround((v.cx1 - v.cx0) * px_per_cell)));
  v.height_px = std::max(1, static_cast<int>(std::lround((v.cy1 - v.cy0) * px_per_cell)));
  return v;
}

cv::Mat render_map(const mrpt::maps::COccupancyGridMap2D& map, const View& v) {
  cv::Mat cells(v.cy1 - v.cy0, v.cx1 - v.cx0, CV_8UC3);
  const int size_x = static_cast<int>(map.getSizeX());
  const int size_y = static_cast<int>(map.getSizeY());
  for (int r = 0; r < cells.rows; ++r) {
    const int cy = v.cy1 - 1 - r;  // image rows run downwards, map y upwards
    for (int c = 0; c < cells.cols; ++c) {
      const int cx = v.cx0 + c;
      if (cx < 0 || cy < 0 || cx >= size_x || cy >= size_y) {
        cells.at<cv::Vec3b>(r, c) = cv::Vec3b(235, 235, 235);  // beyond the map
        continue;
      }
      const float free = map.getCell(cx, cy);
      // Walls stay dark but not black, so the black start marker and text remain legible.
      const auto grey = static_cast<uchar>(std::clamp(70.0 + 185.0 * free, 0.0, 255.0));
      cells.at<cv::Vec3b>(r, c) = cv::Vec3b(grey, grey, grey);
    }
  }
  cv::Mat scaled;
  const double px_per_cell = v.px_per_m * map.getResolution();
  cv::resize(cells, scaled, cv::Size(v.width_px, v.height_px), 0, 0,
             px_per_cell >= 1.0 ? cv::INTER_NEAREST : cv::INTER_AREA);
  return scaled;
}

void draw_polyline(cv::Mat& img, const View& v, const std::vector<Pose2D>& poses,
                   const cv::Scalar& colour, int thickness) {
  if (poses.empty()) return;
  std::vector<cv::Point> pts;
  pts.reserve(poses.size());
  for (const auto& p : poses) pts.push_back(v.fixed(p.x_m, p.y_m));
  cv::polylines(img, pts, false, colour, thickness, cv::LINE_AA, kShift);
}

// Beside a marker: above right by default, flipped left or below where it would leave the
// picture; where neither side has room (a long id in a narrow corridor's picture), centred
// above the marker and kept inside.
void draw_label(cv::Mat& img, const std::string& text, const cv::Point2d& marker_px, int radius_px,
                double scale) {
  int base = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &base);
  const int gap_px = radius_px + 4;
  int x = static_cast<int>(marker_px.x) + gap_px;
  int y = static_cast<int>(marker_px.y) - gap_px;
  if (x + size.width > img.cols) x = static_cast<int>(marker_px.x) - gap_px - size.width;
  if (x < 0) {
    x = std::clamp(static_cast<int>(marker_px.x) - size.width / 2, 0,
                   std::max(0, img.cols - size.width));
  }
  if (y - size.height < 0) y = static_cast<int>(marker_px.y) + gap_px + size.height;
  // A white halo keeps the text readable over walls and paths.
  cv::putText(img, text, cv::Point(x, y), kFont, scale, cv::Scalar(255, 255, 255), 4, cv::LINE_AA);
  cv::putText(img, text, cv::Point(x, y), kFont, scale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
}

void draw_pose_marker(cv::Mat& img, const View& v, const Pose2D& pose, const cv::Scalar& fill,
                      int radius_px, int arrow_px) {
  const cv::Point2d c = v.to_px(pose.x_m, pose.y_m);
  const cv::Point2d tip =
      c + cv::Point2d(std::cos(pose.yaw_rad), -std::sin(pose.yaw_rad)) * arrow_px;
  const cv::Point ci(static_cast<int>(std::lround(c.x)), static_cast<int>(std::lround(c.y)));
  const cv::Point ti(static_cast<int>(std::lround(tip.x)), static_cast<int>(std::lround(tip.y)));
  cv::arrowedLine(img, ci, ti, cv::Scalar(0, 0, 0), 4, cv::LINE_AA, 0, 0.35);
  cv::arrowedLine(img, ci, ti, fill, 2, cv::LINE_AA, 0, 0.35);
  cv::circle(img, ci, radius_px + 1, cv::Scalar(0, 0, 0), -1, cv::LINE_AA);
  cv::circle(img, ci, radius_px, fill, -1, cv::LINE_AA);
}

// One legend entry: a swatch (line or dot) and its text.
struct LegendEntry {
  enum class Swatch { line, dot, scale_bar } swatch;
  cv::Scalar colour;
  std::string text;
  int bar_px = 0;  // scale_bar only
};

constexpr double kLegendScale = 0.5;
constexpr int kLegendRowPx = 26;
constexpr int kSwatchPx = 30;

int legend_entry_width(const LegendEntry& e) {
  int base = 0;
  const int text_w = cv::getTextSize(e.text, kFont, kLegendScale, 1, &base).width;
  const int swatch = e.swatch == LegendEntry::Swatch::scale_bar ? e.bar_px : kSwatchPx;
  return swatch + 8 + text_w + 22;
}

// Flow layout: entries left to right, wrapping at the canvas width. Returns each entry's
// top-left corner relative to the legend strip, and the strip's height.
std::vector<cv::Point> layout_legend(const std::vector<LegendEntry>& entries, int width_px,
                                     int first_row_y, int& height_px) {
  std::vector<cv::Point> at;
  int x = 10, y = first_row_y;
  for (const auto& e : entries) {
    const int w = legend_entry_width(e);
    if (x > 10 && x + w > width_px) {
      x = 10;
      y += kLegendRowPx;
    }
    at.emplace_back(x, y);
    x += w;
  }
  height_px = y + kLegendRowPx + 6;
  return at;
}

// The longest of 1, 2, 5, 10, ... m that stays under a fifth of the width.
std::pair<double, int> scale_bar(const View& v, int width_px) {
  double metres = 1.0;
  for (double m : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
    if (m * v.px_per_m <= width_px / 5.0) metres = m;
  }
  return {metres, static_cast<int>(std::lround(metres * v.px_per_m))};
}

}  // namespace

std::vector<Pose2D> simplify_polyline(const std::vector<Pose2D>& points, double tolerance_m) {
  if (points.size() <= 2) return points;
  const auto distance_to_segment_m = [](const Pose2D& p, const Pose2D& a, const Pose2D& b) {
    const Eigen::Vector2d ab(b.x_m - a.x_m, b.y_m - a.y_m), ap(p.x_m - a.x_m, p.y_m - a.y_m);
    const double len2 = ab.squaredNorm();
    const double s = len2 > 0.0 ? std::clamp(ap.dot(ab) / len2, 0.0, 1.0) : 0.0;
    return (ap - s * ab).norm();
  };
  std::vector<bool> keep(points.size(), false);
  keep.front() = keep.back() = true;
  // An explicit stack: a day's trace is long enough that recursion depth is not a given.
  std::vector<std::pair<std::size_t, std::size_t>> spans{{0, points.size() - 1}};
  while (!spans.empty()) {
    const auto [first, last] = spans.back();
    spans.pop_back();
    double worst_m = -1.0;
    std::size_t worst = first;
    for (std::size_t i = first + 1; i < last; ++i) {
      const double d = distance_to_segment_m(points[i], points[first], points[last]);
      if (d > worst_m) {
        worst_m = d;
        worst = i;
      }
    }
    if (worst_m > tolerance_m) {
      keep[worst] = true;
      spans.push_back({first, worst});
      spans.push_back({worst, last});
    }
  }
  std::vector<Pose2D> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (keep[i]) out.push_back(points[i]);
  }
  return out;
}

RgbColour outcome_colour(const std::string& outcome) {
  if (outcome == "projected") return {0, 170, 0};
  if (outcome == "skipped") return {255, 140, 0};
  if (outcome == "failed") return {220, 0, 0};
  return {150, 150, 150};
}

cv::Mat render_tour_picture(const TourPictureInput& input) {
  if (!input.map) throw std::invalid_argument("render_tour_picture: no map");
  const View v = make_view(input);
  const int canvas_w = std::max(v.width_px, kMinCanvasWidthPx);

  std::vector<LegendEntry> legend;
  legend.push_back({LegendEntry::Swatch::line, bgr(kPlannedPathColour), "planned path"});
  legend.push_back(
      {LegendEntry::Swatch::line, bgr(kEstimatedTrajectoryColour), "estimated trajectory"});
  if (!input.true_trajectory.empty()) {
    legend.push_back({LegendEntry::Swatch::line, bgr(kTrueTrajectoryColour), "true trajectory"});
  }
  if (!input.people_samples.empty()) {
    legend.push_back({LegendEntry::Swatch::line, bgr(kPeopleColour), "people (every 0.5 s)"});
  }
  legend.push_back({LegendEntry::Swatch::dot, bgr(kStartColour), "start"});
  bool any_unvisited = false;
  for (const auto& t : input.targets) {
    any_unvisited |= t.outcome != "projected" && t.outcome != "skipped" && t.outcome != "failed";
  }
  for (const char* o : {"projected", "skipped", "failed"}) {
    legend.push_back({LegendEntry::Swatch::dot, bgr(outcome_colour(o)), o});
  }
  if (any_unvisited) {
    legend.push_back({LegendEntry::Swatch::dot, bgr(outcome_colour("")), "not visited"});
  }
  const auto [bar_m, bar_px] = scale_bar(v, canvas_w);
  std::string bar_text = std::to_string(static_cast<int>(bar_m)) + " m";
  legend.push_back({LegendEntry::Swatch::scale_bar, cv::Scalar(0, 0, 0), bar_text, bar_px});

  const int title_px = input.title.empty() ? 0 : 28;
  int legend_h = 0;
  const std::vector<cv::Point> at = layout_legend(legend, canvas_w, title_px + 6, legend_h);

  cv::Mat img(v.height_px + legend_h, canvas_w, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto& map = *input.map;
  // Drawing into the map's region clips markers near the edge there, off the legend.
  cv::Mat area = img(cv::Rect(0, 0, v.width_px, v.height_px));
  render_map(map, v).copyTo(area);

  const int line_px = std::max(2, static_cast<int>(std::lround(v.width_px / 600.0)));
  // Under everything the robot did: the people are the background of its tour.
  for (const Eigen::Vector2d& p : input.people_samples) {
    cv::circle(area, v.to_px(p.x(), p.y()), std::max(1, line_px / 2), bgr(kPeopleColour), -1);
  }
  for (const auto& path : input.planned_paths) {
    draw_polyline(area, v, path, bgr(kPlannedPathColour), line_px + 3);
  }
  draw_polyline(area, v, input.true_trajectory, bgr(kTrueTrajectoryColour), line_px);
  draw_polyline(area, v, input.estimated_trajectory, bgr(kEstimatedTrajectoryColour), line_px);

  const int radius_px = std::max(6, static_cast<int>(std::lround(0.15 * v.px_per_m)));
  const int arrow_px = std::max(24, static_cast<int>(std::lround(0.6 * v.px_per_m)));
  const double label_scale = v.width_px > 900 ? 0.6 : 0.5;
  draw_pose_marker(area, v, input.start, bgr(kStartColour), radius_px, arrow_px);
  for (const auto& t : input.targets) {
    draw_pose_marker(area, v, t.pose, bgr(outcome_colour(t.outcome)), radius_px, arrow_px);
  }
  // Labels after all markers so no marker covers a label.
  draw_label(area, "start", v.to_px(input.start.x_m, input.start.y_m), radius_px, label_scale);
  for (const auto& t : input.targets) {
    draw_label(area, t.id + " (" + (t.outcome.empty() ? "not visited" : t.outcome) + ")",
               v.to_px(t.pose.x_m, t.pose.y_m), radius_px, label_scale);
  }

  // Legend strip.
  const int top = v.height_px;
  cv::line(img, cv::Point(0, top), cv::Point(canvas_w - 1, top), cv::Scalar(0, 0, 0), 1);
  if (!input.title.empty()) {
    cv::putText(img, input.title, cv::Point(10, top + 22), kFont, 0.65, cv::Scalar(0, 0, 0), 2,
                cv::LINE_AA);
  }
  for (std::size_t i = 0; i < legend.size(); ++i) {
    const auto& e = legend[i];
    const cv::Point p = at[i] + cv::Point(0, top);
    const int mid = p.y + kLegendRowPx / 2;
    int swatch_w = kSwatchPx;
    switch (e.swatch) {
      case LegendEntry::Swatch::line:
        cv::line(img, cv::Point(p.x, mid), cv::Point(p.x + kSwatchPx, mid), e.colour, 4,
                 cv::LINE_AA);
        break;
      case LegendEntry::Swatch::dot:
        cv::circle(img, cv::Point(p.x + kSwatchPx / 2, mid), 8, cv::Scalar(0, 0, 0), -1,
                   cv::LINE_AA);
        cv::circle(img, cv::Point(p.x + kSwatchPx / 2, mid), 7, e.colour, -1, cv::LINE_AA);
        break;
      case LegendEntry::Swatch::scale_bar:
        swatch_w = e.bar_px;
        cv::line(img, cv::Point(p.x, mid), cv::Point(p.x + e.bar_px, mid), e.colour, 2);
        cv::line(img, cv::Point(p.x, mid - 5), cv::Point(p.x, mid + 5), e.colour, 2);
        cv::line(img, cv::Point(p.x + e.bar_px, mid - 5), cv::Point(p.x + e.bar_px, mid + 5),
                 e.colour, 2);
        break;
    }
    cv::putText(img, e.text, cv::Point(p.x + swatch_w + 8, mid + 5), kFont, kLegendScale,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return img;
}

void write_tour_picture(const TourPictureInput& input, const std::filesystem::path& png) {
  const cv::Mat img = render_tour_picture(input);
  try {
    if (png.has_parent_path()) make_run_directory(png.parent_path());
    write_run_image(png, img);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write the tour picture " + png.string() + ": " + e.what());
  }
}

}  // namespace projtour
