#include "projtour/navigation/path_planner.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <stdexcept>

namespace projtour::navigation {

namespace {

// Paths keep away from walls up to this much beyond the robot's radius where there is room,
// so the controller's small deviations do not touch them.
constexpr double kComfortMarginM = 0.30;
constexpr double kWallPenalty = 4.0;
// Spacing of the returned path's points.
constexpr double kPathSpacingM = 0.20;

const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};

}  // namespace

InflatedGrid::InflatedGrid(const mrpt::maps::COccupancyGridMap2D& map, double robot_radius_m)
    : size_x_(static_cast<int>(map.getSizeX())),
      size_y_(static_cast<int>(map.getSizeY())),
      x_min_m_(map.getXMin()),
      y_min_m_(map.getYMin()),
      resolution_m_(map.getResolution()),
      robot_radius_m_(robot_radius_m) {
  if (size_x_ <= 0 || size_y_ <= 0) throw std::invalid_argument("the occupancy grid is empty");
  obstacle_.assign(static_cast<std::size_t>(size_x_) * size_y_, 0);
  // distanceTransform measures to the nearest zero pixel; the grid's border counts as an
  // obstacle so the robot never plans off the map.
  cv::Mat free_mask(size_y_, size_x_, CV_8UC1);
  for (int cy = 0; cy < size_y_; ++cy) {
    for (int cx = 0; cx < size_x_; ++cx) {
      const bool border = cx == 0 || cy == 0 || cx == size_x_ - 1 || cy == size_y_ - 1;
      const bool obstacle = border || map.getCell(cx, cy) <= kFreeCellThreshold;
      obstacle_[index(cx, cy)] = obstacle ? 1 : 0;
      free_mask.at<std::uint8_t>(cy, cx) = obstacle ? 0 : 255;
    }
  }
  cv::Mat distance_px;
  cv::distanceTransform(free_mask, distance_px, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  clearance_m_.resize(obstacle_.size());
  for (int cy = 0; cy < size_y_; ++cy) {
    for (int cx = 0; cx < size_x_; ++cx) {
      // Centre-to-centre distance minus half a cell: the distance to the obstacle cell's edge.
      const float d_px = distance_px.at<float>(cy, cx);
      clearance_m_[index(cx, cy)] =
          d_px <= 0.0f ? 0.0f : static_cast<float>((d_px - 0.5) * resolution_m_);
    }
  }
}

bool InflatedGrid::cell_of(const Eigen::Vector2d& p_m, int& cx, int& cy) const {
  const double fx = (p_m.x() - x_min_m_) / resolution_m_;
  const double fy = (p_m.y() - y_min_m_) / resolution_m_;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < size_x_ && fy < size_y_)) return false;
  cx = static_cast<int>(fx);
  cy = static_cast<int>(fy);
  return true;
}

bool InflatedGrid::contains(const Eigen::Vector2d& p_m) const {
  int cx = 0, cy = 0;
  return cell_of(p_m, cx, cy);
}

Eigen::Vector2d InflatedGrid::centre_of(int cx, int cy) const {
  return {x_min_m_ + (cx + 0.5) * resolution_m_, y_min_m_ + (cy + 0.5) * resolution_m_};
}

bool InflatedGrid::is_free_space(const Eigen::Vector2d& p_m) const {
  int cx = 0, cy = 0;
  return cell_of(p_m, cx, cy) && obstacle_[index(cx, cy)] == 0;
}

bool InflatedGrid::fits(const Eigen::Vector2d& p_m) const {
  int cx = 0, cy = 0;
  return cell_of(p_m, cx, cy) && fits_cell(cx, cy);
}

bool InflatedGrid::fits_cell(int cx, int cy) const {
  return cx >= 0 && cy >= 0 && cx < size_x_ && cy < size_y_ &&
         clearance_m_[index(cx, cy)] > robot_radius_m_;
}

double InflatedGrid::clearance_cell_m(int cx, int cy) const {
  return clearance_m_[index(cx, cy)];
}

bool InflatedGrid::segment_fits(const Eigen::Vector2d& a_m, const Eigen::Vector2d& b_m) const {
  const double length_m = (b_m - a_m).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length_m / (0.5 * resolution_m_))));
  for (int i = 0; i <= steps; ++i) {
    if (!fits(a_m + (b_m - a_m) * (static_cast<double>(i) / steps))) return false;
  }
  return true;
}

void InflatedGrid::add_obstacles(const std::vector<Eigen::Vector2d>& points_m) {
  for (const Eigen::Vector2d& p : points_m) {
    int cx = 0, cy = 0;
    if (!cell_of(p, cx, cy) || obstacle_[index(cx, cy)] != 0) continue;
    obstacle_[index(cx, cy)] = 1;
    update_clearance_around(cx, cy);
  }
}

void InflatedGrid::update_clearance_around(int ox, int oy) {
  // Only clearances up to the radius plus the comfort margin change a plan.
  const double reach_m = robot_radius_m_ + kComfortMarginM + resolution_m_;
  const int r = static_cast<int>(std::ceil(reach_m / resolution_m_));
  for (int cy = std::max(0, oy - r); cy <= std::min(size_y_ - 1, oy + r); ++cy) {
    for (int cx = std::max(0, ox - r); cx <= std::min(size_x_ - 1, ox + r); ++cx) {
      const double d_px = std::hypot(cx - ox, cy - oy);
      const float c = d_px <= 0.0 ? 0.0f : static_cast<float>((d_px - 0.5) * resolution_m_);
      float& current = clearance_m_[index(cx, cy)];
      current = std::min(current, c);
    }
  }
}

PathPlanner::PathPlanner(const mrpt::maps::COccupancyGridMap2D& map, double robot_radius_m)
    : grid_(map, robot_radius_m) {}

std::optional<int> PathPlanner::snap_to_fitting_cell(const Eigen::Vector2d& p_m) const {
  int ox = 0, oy = 0;
  if (!grid_.cell_of(p_m, ox, oy)) return std::nullopt;
  if (grid_.fits_cell(ox, oy)) return oy * grid_.size_x() + ox;
  const int r = static_cast<int>(std::ceil(grid_.robot_radius_m() / grid_.resolution_m()));
  std::optional<int> best;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const double d2 = dx * dx + dy * dy;
      if (d2 > r * r || d2 >= best_d2 || !grid_.fits_cell(ox + dx, oy + dy)) continue;
      best_d2 = d2;
      best = (oy + dy) * grid_.size_x() + (ox + dx);
    }
  }
  return best;
}

std::optional<PlannedPath> PathPlanner::plan(const Eigen::Vector2d& start_m,
                                             const Eigen::Vector2d& goal_m) const {
  const auto start = snap_to_fitting_cell(start_m);
  const auto goal = snap_to_fitting_cell(goal_m);
  if (!start || !goal) return std::nullopt;
  const int nx = grid_.size_x();
  const std::size_t n = static_cast<std::size_t>(nx) * grid_.size_y();
  const int gx = *goal % nx, gy = *goal / nx;
  const double comfort_m = grid_.robot_radius_m() + kComfortMarginM;
  auto heuristic = [&](int cx, int cy) {
    const double dx = std::abs(cx - gx), dy = std::abs(cy - gy);
    return std::max(dx, dy) + (std::sqrt(2.0) - 1.0) * std::min(dx, dy);
  };

  // A* in cell units; the wall penalty only adds cost, so the octile heuristic stays admissible.
  std::vector<float> g(n, std::numeric_limits<float>::infinity());
  std::vector<int> parent(n, -1);
  std::vector<std::uint8_t> closed(n, 0);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  g[*start] = 0.0f;
  open.push({heuristic(*start % nx, *start / nx), *start});
  while (!open.empty()) {
    const int current = open.top().second;
    open.pop();
    if (closed[current]) continue;
    closed[current] = 1;
    if (current == *goal) break;
    const int cx = current % nx, cy = current / nx;
    for (int k = 0; k < 8; ++k) {
      const int x = cx + kDx[k], y = cy + kDy[k];
      if (!grid_.fits_cell(x, y)) continue;
      // No cutting corners diagonally between two cells where the robot does not fit.
      if (k >= 4 && (!grid_.fits_cell(cx + kDx[k], cy) || !grid_.fits_cell(cx, cy + kDy[k]))) {
        continue;
      }
      const int next = y * nx + x;
      if (closed[next]) continue;
      const double tightness =
          std::max(0.0, comfort_m - grid_.clearance_cell_m(x, y)) / kComfortMarginM;
      const double step = (k < 4 ? 1.0 : std::sqrt(2.0)) * (1.0 + kWallPenalty * tightness);
      const double candidate = g[current] + step;
      if (candidate < g[next]) {
        g[next] = static_cast<float>(candidate);
        parent[next] = current;
        open.push({candidate + heuristic(x, y), next});
      }
    }
  }
  if (!closed[*goal]) return std::nullopt;

  std::vector<Eigen::Vector2d> cells;
  for (int c = *goal; c != -1; c = parent[c]) cells.push_back(grid_.centre_of(c % nx, c / nx));
  std::reverse(cells.begin(), cells.end());

  PlannedPath path;
  path.points_m.push_back(start_m);
  double since_last_m = 0.0;
  for (std::size_t i = 1; i + 1 < cells.size(); ++i) {
    since_last_m += (cells[i] - cells[i - 1]).norm();
    if (since_last_m >= kPathSpacingM) {
      path.points_m.push_back(cells[i]);
      since_last_m = 0.0;
    }
  }
  if (cells.size() > 1 || (goal_m - start_m).norm() > 1e-9) path.points_m.push_back(goal_m);
  for (std::size_t i = 1; i < path.points_m.size(); ++i) {
    path.length_m += (path.points_m[i] - path.points_m[i - 1]).norm();
  }
  return path;
}

std::optional<double> PathPlanner::path_length_m(const Eigen::Vector2d& start_m,
                                                 const Eigen::Vector2d& goal_m) const {
  const auto path = plan(start_m, goal_m);
  if (!path) return std::nullopt;
  return path->length_m;
}

PathPlanner::Reachable PathPlanner::reachable_from(const Eigen::Vector2d& start_m) const {
  Reachable out;
  out.grid_ = &grid_;
  const int nx = grid_.size_x();
  out.mask_.assign(static_cast<std::size_t>(nx) * grid_.size_y(), 0);
  const auto start = snap_to_fitting_cell(start_m);
  if (!start) return out;
  out.empty_ = false;
  std::vector<int> stack{*start};
  out.mask_[*start] = 1;
  while (!stack.empty()) {
    const int current = stack.back();
    stack.pop_back();
    const int cx = current % nx, cy = current / nx;
    for (int k = 0; k < 8; ++k) {
      const int x = cx + kDx[k], y = cy + kDy[k];
      if (!grid_.fits_cell(x, y)) continue;
      if (k >= 4 && (!grid_.fits_cell(cx + kDx[k], cy) || !grid_.fits_cell(cx, cy + kDy[k]))) {
        continue;
      }
      const int next = y * nx + x;
      if (out.mask_[next]) continue;
      out.mask_[next] = 1;
      stack.push_back(next);
    }
  }
  return out;
}

bool PathPlanner::Reachable::contains(const Eigen::Vector2d& p_m) const {
  int cx = 0, cy = 0;
  if (grid_ == nullptr || !grid_->cell_of(p_m, cx, cy)) return false;
  return mask_[static_cast<std::size_t>(cy) * grid_->size_x() + cx] != 0;
}

}  // namespace projtour::navigation
