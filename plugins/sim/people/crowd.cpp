// The people walking through the building.
#include "people/crowd.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "world/random_streams.hpp"

namespace projtour::sim {
namespace {

// Cells that read as free on a map (the planner's and the localizer's threshold).
constexpr float kFree = 0.5f;

}  // namespace

Crowd::Crowd(const host::CrowdSpec& spec, const mrpt::maps::COccupancyGridMap2D* walls,
             const std::vector<Footprint>& objects, const std::vector<Eigen::Vector2d>& homes,
             int first_object_id, std::uint64_t seed)
    : spec_(spec), homes_(homes), first_object_id_(first_object_id), rng_(seed) {
  if (walls != nullptr) {
    cols_ = static_cast<int>(walls->getSizeX());
    rows_ = static_cast<int>(walls->getSizeY());
    x_min_m_ = walls->getXMin();
    y_min_m_ = walls->getYMin();
    resolution_m_ = walls->getResolution();
    cv::Mat open(rows_, cols_, CV_8UC1);
    for (int j = 0; j < rows_; ++j) {
      for (int i = 0; i < cols_; ++i) {
        open.at<std::uint8_t>(j, i) = walls->getCell(i, j) > kFree ? 255 : 0;
      }
    }
    for (const Footprint& f : objects) {
      const double reach = f.half_m.norm() + resolution_m_;
      for (int j = std::max(0, walls->y2idx(f.centre_m.y() - reach));
           j <= std::min(rows_ - 1, walls->y2idx(f.centre_m.y() + reach)); ++j) {
        for (int i = std::max(0, walls->x2idx(f.centre_m.x() - reach));
             i <= std::min(cols_ - 1, walls->x2idx(f.centre_m.x() + reach)); ++i) {
          const Eigen::Vector2d c(walls->idx2x(i), walls->idx2y(j));
          if (f.distance_m(c) <= 0.5 * resolution_m_) open.at<std::uint8_t>(j, i) = 0;
        }
      }
    }
    cv::Mat clearance_cells;
    cv::distanceTransform(open, clearance_cells, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
    free_.assign(static_cast<std::size_t>(rows_) * cols_, 0);
    const float needed = static_cast<float>((spec.radius_m + 0.05) / resolution_m_);
    for (int j = 0; j < rows_; ++j) {
      for (int i = 0; i < cols_; ++i) {
        free_[static_cast<std::size_t>(j) * cols_ + i] = clearance_cells.at<float>(j, i) > needed;
      }
    }
  }
  auto add = [&](const host::PersonSpec& s, bool random_start) {
    Person p;
    p.route_m = s.route_m;
    p.loop = s.loop;
    p.speed_mps = s.speed_mps;
    p.pause_each_s = s.pause_s;
    p.start_s = s.start_s;
    p.object_id = first_object_id_ + static_cast<int>(people_.size());
    if (!p.route_m.empty()) {
      p.at_m = p.route_m.front();
      p.next = 1;
      p.goal_m = p.route_m[1];
    } else {
      if (s.start_m) {
        p.at_m = *s.start_m;
      } else if (random_start && !homes_.empty()) {
        // A free spot 1-5 m from a seeded home, in sight of it.
        const Eigen::Vector2d home = homes_[rng_() % homes_.size()];
        p.at_m = home;
        for (int tries = 0; tries < 64; ++tries) {
          const double a = uniform(rng_, 0.0, 2.0 * kPi), r = uniform(rng_, 1.0, 5.0);
          const Eigen::Vector2d q = home + r * Eigen::Vector2d(std::cos(a), std::sin(a));
          if (walkable(q) && line_walkable(home, q)) {
            p.at_m = q;
            break;
          }
        }
      }
      p.home_m = p.at_m;
      p.goal_m = p.at_m;
    }
    people_.push_back(std::move(p));
  };
  for (const host::PersonSpec& s : spec.list) add(s, false);
  for (int k = 0; k < spec.walkers; ++k) {
    host::PersonSpec s;
    s.speed_mps = uniform(rng_, spec.min_speed_mps, spec.max_speed_mps);
    add(s, true);
  }
  update_shapes();
}

void Crowd::add_scripted(const std::vector<Eigen::Vector2d>& route,
                         const std::vector<double>& pause_s, double speed_mps, double start_s) {
  if (route.size() < 2) return;
  Person p;
  p.route_m = route;
  p.pause_s = pause_s;
  p.scripted = true;
  p.loop = false;
  p.speed_mps = speed_mps;
  p.start_s = start_s;
  p.at_m = route.front();
  p.next = 1;
  p.goal_m = route[1];
  p.object_id = first_object_id_ + static_cast<int>(people_.size());
  people_.push_back(std::move(p));
}

bool Crowd::walkable(const Eigen::Vector2d& p) const {
  if (free_.empty()) return true;
  const int i = static_cast<int>(std::floor((p.x() - x_min_m_) / resolution_m_));
  const int j = static_cast<int>(std::floor((p.y() - y_min_m_) / resolution_m_));
  if (i < 0 || j < 0 || i >= cols_ || j >= rows_) return false;
  return free_[static_cast<std::size_t>(j) * cols_ + i] != 0;
}

bool Crowd::line_walkable(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
  const double length = (b - a).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * resolution_m_))));
  for (int k = 0; k <= steps; ++k) {
    if (!walkable(a + (b - a) * (static_cast<double>(k) / steps))) return false;
  }
  return true;
}

void Crowd::choose_goal(Person& p) {
  // Somewhere in sight within 4 m of home: people mill about the places the tour goes to.
  for (int tries = 0; tries < 32; ++tries) {
    const double a = uniform(rng_, 0.0, 2.0 * kPi), r = uniform(rng_, 1.0, 6.0);
    const Eigen::Vector2d q = p.at_m + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    if ((q - p.home_m).norm() > 4.0 || !walkable(q) || !line_walkable(p.at_m, q)) continue;
    p.goal_m = q;
    return;
  }
  p.goal_m = p.home_m;  // back home when nothing else is in sight
  if (!line_walkable(p.at_m, p.home_m)) p.goal_m = p.at_m;
}

void Crowd::step(double t_s, double dt_s, const Eigen::Vector2d& robot_m, double keep_off_m) {
  moved_ = false;
  for (Person& p : people_) {
    if (p.gone) continue;
    if (t_s + 1e-9 < p.start_s) continue;
    if (!p.present) {
      p.present = true;
      moved_ = true;
    }
    if (t_s < p.paused_until_s) continue;
    const Eigen::Vector2d to_goal = p.goal_m - p.at_m;
    const double distance = to_goal.norm();
    if (distance < 1e-6) {
      // At the goal: the next waypoint, a pause, or a new goal.
      if (!p.route_m.empty()) {
        const double pause =
            p.scripted ? (p.next < p.pause_s.size() ? p.pause_s[p.next] : 0.0) : p.pause_each_s;
        if (p.next + 1 < p.route_m.size()) {
          ++p.next;
        } else if (p.loop) {
          p.next = 0;
        } else {
          if (p.scripted) {
            p.gone = true;
            p.present = false;
            moved_ = true;
          }
          continue;
        }
        p.goal_m = p.route_m[p.next];
        p.paused_until_s = t_s + pause;
      } else {
        p.paused_until_s = t_s + uniform(rng_, 0.0, spec_.max_pause_s);
        choose_goal(p);
      }
      continue;
    }
    const double step = std::min(distance, p.speed_mps * dt_s);
    const Eigen::Vector2d next = p.at_m + to_goal * (step / distance);
    // People give the robot room: nobody steps nearer to it than keep_off_m.
    const double limit = keep_off_m + spec_.radius_m;
    if ((next - robot_m).norm() < limit && (next - robot_m).norm() < (p.at_m - robot_m).norm()) {
      p.blocked_s += dt_s;
      if (p.blocked_s > 2.0) {
        p.blocked_s = 0.0;
        if (p.route_m.empty()) {
          choose_goal(p);
        } else if (!p.scripted) {
          // Turn back to the previous waypoint; the route goes on from there.
          p.next = (p.next + p.route_m.size() - 1) % p.route_m.size();
          p.goal_m = p.route_m[p.next];
        }
      }
      continue;
    }
    p.blocked_s = 0.0;
    p.at_m = next;
    moved_ = true;
  }
  update_shapes();
}

std::vector<std::pair<int, Eigen::Vector2d>> Crowd::positions() const {
  std::vector<std::pair<int, Eigen::Vector2d>> out;
  for (std::size_t i = 0; i < people_.size(); ++i) {
    if (people_[i].present) out.emplace_back(static_cast<int>(i), people_[i].at_m);
  }
  return out;
}

void Crowd::update_shapes() {
  shapes_.clear();
  // Within the body's circle seen from above (the scene's ray test relies on it).
  const float head_r = std::min(0.11f, static_cast<float>(spec_.radius_m));
  for (const Person& p : people_) {
    if (!p.present) continue;
    PersonShape s;
    s.centre_m = p.at_m.cast<float>();
    s.radius_m = static_cast<float>(spec_.radius_m);
    s.head_radius_m = head_r;
    s.head_z_m = static_cast<float>(spec_.height_m) - head_r;
    s.body_top_m = s.head_z_m - head_r;
    s.object_id = p.object_id;
    shapes_.push_back(s);
  }
}

}  // namespace projtour::sim
