#pragma once
// Planning for a round robot on an occupancy grid: the grid is turned into a clearance field (the
// distance from each cell to the nearest cell that is not known free), so "the robot fits here"
// is clearance > radius, and A* runs over the cells where it fits.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour::navigation {

// Cells with a free probability above this are free space; occupied and unknown cells are not.
inline constexpr float kFreeCellThreshold = 0.6f;

class InflatedGrid {
 public:
  InflatedGrid(const mrpt::maps::COccupancyGridMap2D& map, double robot_radius_m);

  int size_x() const { return size_x_; }
  int size_y() const { return size_y_; }
  double resolution_m() const { return resolution_m_; }
  double robot_radius_m() const { return robot_radius_m_; }

  bool contains(const Eigen::Vector2d& p_m) const;
  // False when outside the grid.
  bool cell_of(const Eigen::Vector2d& p_m, int& cx, int& cy) const;
  Eigen::Vector2d centre_of(int cx, int cy) const;

  // The map says free space (the robot's centre may still be too close to a wall).
  bool is_free_space(const Eigen::Vector2d& p_m) const;
  // The whole robot fits here.
  bool fits(const Eigen::Vector2d& p_m) const;
  bool fits_cell(int cx, int cy) const;
  double clearance_cell_m(int cx, int cy) const;
  // Every point of the segment (sampled at half a cell) fits.
  bool segment_fits(const Eigen::Vector2d& a_m, const Eigen::Vector2d& b_m) const;

  // Marks points as obstacles (what the laser sees that the map lacks) and updates the
  // clearance around them.
  void add_obstacles(const std::vector<Eigen::Vector2d>& points_m);

 private:
  int index(int cx, int cy) const { return cy * size_x_ + cx; }
  void update_clearance_around(int cx, int cy);

  int size_x_ = 0, size_y_ = 0;
  double x_min_m_ = 0.0, y_min_m_ = 0.0, resolution_m_ = 0.05, robot_radius_m_ = 0.0;
  std::vector<std::uint8_t> obstacle_;  // 1 where the cell is not free space
  std::vector<float> clearance_m_;      // distance from the cell centre to the nearest obstacle
};

struct PlannedPath {
  std::vector<Eigen::Vector2d> points_m;  // from the start to the goal
  double length_m = 0.0;
};

class PathPlanner {
 public:
  PathPlanner(const mrpt::maps::COccupancyGridMap2D& map, double robot_radius_m);

  // Shortest path (with a penalty for passing close to walls) over cells where the robot fits.
  // A start or goal a little too close to a wall (within the robot's radius) is moved to the
  // nearest cell where it fits. nullopt when there is no path.
  std::optional<PlannedPath> plan(const Eigen::Vector2d& start_m,
                                  const Eigen::Vector2d& goal_m) const;
  std::optional<double> path_length_m(const Eigen::Vector2d& start_m,
                                      const Eigen::Vector2d& goal_m) const;

  // Every cell reachable from `start_m` (one flood fill, for checking many goals).
  class Reachable {
   public:
    bool contains(const Eigen::Vector2d& p_m) const;
    // True when the start left no room for the robot at all.
    bool empty() const { return empty_; }

   private:
    friend class PathPlanner;
    const InflatedGrid* grid_ = nullptr;
    std::vector<std::uint8_t> mask_;
    bool empty_ = true;
  };
  Reachable reachable_from(const Eigen::Vector2d& start_m) const;

  InflatedGrid& grid() { return grid_; }
  const InflatedGrid& grid() const { return grid_; }

 private:
  // The nearest cell within the robot's radius where the robot fits, or nullopt.
  std::optional<int> snap_to_fitting_cell(const Eigen::Vector2d& p_m) const;

  InflatedGrid grid_;
};

}  // namespace projtour::navigation
