// The building that is not the map: its walls and its unmapped objects.
#include "bodies/building.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "projtour/contract/geometry.hpp"
#include "world/random_streams.hpp"

namespace projtour::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Cells that read as free on a map (the planner's and the localizer's threshold).
constexpr float kFree = 0.5f;
constexpr float kOccupied = 0.5f;

bool in_grid(const mrpt::maps::COccupancyGridMap2D& g, int i, int j) {
  return i >= 0 && j >= 0 && i < static_cast<int>(g.getSizeX()) &&
         j < static_cast<int>(g.getSizeY());
}

double segment_distance_m(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                          const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

Eigen::Isometry3d on_floor(const Pose2D& pose, double z_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(pose.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose.x_m, pose.y_m, z_m);
  return T;
}

}  // namespace

perception::TriangleMesh prism_mesh(double radius_m, double height_m, int sides) {
  perception::TriangleMesh mesh;
  for (int k = 0; k < sides; ++k) {
    const double a = 2.0 * kPi * k / sides;
    const float x = static_cast<float>(radius_m * std::cos(a));
    const float y = static_cast<float>(radius_m * std::sin(a));
    mesh.vertices.emplace_back(x, y, 0.0f);
    mesh.vertices.emplace_back(x, y, static_cast<float>(height_m));
  }
  const int bottom = 2 * sides, top = 2 * sides + 1;
  mesh.vertices.emplace_back(0.0f, 0.0f, 0.0f);
  mesh.vertices.emplace_back(0.0f, 0.0f, static_cast<float>(height_m));
  for (int k = 0; k < sides; ++k) {
    const int j = (k + 1) % sides;
    mesh.triangles.emplace_back(2 * k, 2 * j, 2 * j + 1);
    mesh.triangles.emplace_back(2 * k, 2 * j + 1, 2 * k + 1);
    mesh.triangles.emplace_back(bottom, 2 * j, 2 * k);
    mesh.triangles.emplace_back(top, 2 * k + 1, 2 * j + 1);
  }
  return mesh;
}

double Footprint::distance_m(const Eigen::Vector2d& p) const {
  if (shape == Shape::circle) return (p - centre_m).norm() - half_m.x();
  const Eigen::Rotation2Dd R(yaw_rad);
  const Eigen::Vector2d q = R.inverse() * (p - centre_m);
  const Eigen::Vector2d d = q.cwiseAbs() - half_m;
  const double outside = d.cwiseMax(0.0).norm();
  return outside > 0.0 ? outside : std::max(d.x(), d.y());
}

double Footprint::ray_hit_m(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir) const {
  if (shape == Shape::circle) {
    const Eigen::Vector2d oc = origin - centre_m;
    const double b = oc.dot(dir), c = oc.squaredNorm() - half_m.x() * half_m.x();
    const double disc = b * b - c;
    if (disc < 0.0) return kInf;
    const double t = -b - std::sqrt(disc);
    return t > 0.0 ? t : kInf;
  }
  // Slabs in the rectangle's own frame.
  const Eigen::Rotation2Dd R_inv(-yaw_rad);
  const Eigen::Vector2d o = R_inv * (origin - centre_m), d = R_inv * dir;
  double t0 = 0.0, t1 = kInf;
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (std::abs(o[k]) > half_m[k]) return kInf;
      continue;
    }
    double a = (-half_m[k] - o[k]) / d[k], b = (half_m[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return kInf;
  }
  return t0 > 0.0 ? t0 : kInf;  // from inside: the laser sees nothing of it
}

Eigen::Vector2d map_point_of(const Eigen::Vector2d& building_m, const host::MapErrorSpec& error,
                             const Eigen::Vector2d& about_m) {
  const Eigen::Vector2d centre = error.rotation_about_m.value_or(about_m);
  const Eigen::Rotation2Dd R_inv(-deg_to_rad(error.rotation_deg));
  const Eigen::Vector2d shift(error.shift_x_m, error.shift_y_m);
  return centre + R_inv * (building_m - shift - centre);
}

std::shared_ptr<mrpt::maps::COccupancyGridMap2D> building_walls(
    const mrpt::maps::COccupancyGridMap2D& map, const host::MapErrorSpec& error,
    const Eigen::Vector2d& about_m) {
  auto out = std::make_shared<mrpt::maps::COccupancyGridMap2D>(map);
  const int nx = static_cast<int>(map.getSizeX()), ny = static_cast<int>(map.getSizeY());
  const double res = map.getResolution();
  if (error.rotation_deg != 0.0 || error.shift_x_m != 0.0 || error.shift_y_m != 0.0) {
    // Each building cell takes the map cell it came from (nearest): the map is the building
    // moved back.
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const Eigen::Vector2d q =
            map_point_of(Eigen::Vector2d(map.idx2x(i), map.idx2y(j)), error, about_m);
        const int si = map.x2idx(q.x()), sj = map.y2idx(q.y());
        out->setCell(i, j, in_grid(map, si, sj) ? map.getCell(si, sj) : 0.5f);
      }
    }
  }
  if (error.wall_thinning_m > 0.0) {
    cv::Mat occupied(ny, nx, CV_8UC1);
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        occupied.at<std::uint8_t>(j, i) = out->getCell(i, j) < kOccupied ? 255 : 0;
      }
    }
    // Distance (cells) from each occupied cell to the nearest one that is not; a wall's middle
    // is where that distance peaks across it, and stays, so no wall vanishes.
    cv::Mat depth_cells, peak;
    cv::distanceTransform(occupied, depth_cells, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
    const int reach = static_cast<int>(std::ceil(error.wall_thinning_m / res)) + 1;
    cv::dilate(
        depth_cells, peak,
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * reach + 1, 2 * reach + 1)));
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const float d = depth_cells.at<float>(j, i);
        if (d <= 0.0f) continue;
        const bool middle = d >= peak.at<float>(j, i) - 0.5f;
        if (!middle && (d - 0.5) * res < error.wall_thinning_m) out->setCell(i, j, 1.0f);
      }
    }
  }
  for (const host::WallSegmentSpec& w : error.missing_walls) paint_segment(*out, w, 1.0f);
  for (const host::WallSegmentSpec& w : error.extra_walls) paint_segment(*out, w, 0.0f);
  return out;
}

void paint_segment(mrpt::maps::COccupancyGridMap2D& grid, const host::WallSegmentSpec& wall,
                   float free_p) {
  const double res = grid.getResolution();
  const double half = 0.5 * wall.thickness_m;
  const Eigen::Vector2d lo = wall.a_m.cwiseMin(wall.b_m).array() - half - res;
  const Eigen::Vector2d hi = wall.a_m.cwiseMax(wall.b_m).array() + half + res;
  for (int j = grid.y2idx(lo.y()); j <= grid.y2idx(hi.y()); ++j) {
    for (int i = grid.x2idx(lo.x()); i <= grid.x2idx(hi.x()); ++i) {
      if (!in_grid(grid, i, j)) continue;
      const Eigen::Vector2d c(grid.idx2x(i), grid.idx2y(j));
      // A thin wall still takes the cells it crosses.
      if (segment_distance_m(c, wall.a_m, wall.b_m) <= std::max(half, 0.5 * res)) {
        grid.setCell(i, j, free_p);
      }
    }
  }
}

Footprint glass_footprint(const host::WallSegmentSpec& wall, const std::string& name) {
  Footprint f;
  f.shape = Footprint::Shape::rect;
  f.centre_m = 0.5 * (wall.a_m + wall.b_m);
  const Eigen::Vector2d ab = wall.b_m - wall.a_m;
  f.yaw_rad = std::atan2(ab.y(), ab.x());
  f.half_m = Eigen::Vector2d(0.5 * ab.norm(), 0.5 * wall.thickness_m);
  f.z_min_m = 0.0;
  f.z_max_m = 2.5;
  f.name = name;
  return f;
}

Footprint object_footprint(const host::WorldObjectSpec& object, const std::string& name) {
  Footprint f;
  f.centre_m = Eigen::Vector2d(object.pose.x_m, object.pose.y_m);
  f.yaw_rad = object.pose.yaw_rad;
  if (object.shape == host::WorldObjectSpec::Shape::cylinder) {
    f.shape = Footprint::Shape::circle;
    f.half_m = Eigen::Vector2d::Constant(0.5 * object.size_x_m);
  } else {
    f.shape = Footprint::Shape::rect;
    f.half_m = Eigen::Vector2d(0.5 * object.size_x_m, 0.5 * object.size_y_m);
  }
  f.z_min_m = 0.0;
  f.z_max_m = object.height_m;
  f.name = name;
  return f;
}

void add_object(SceneBuilder& builder, const host::WorldObjectSpec& object, int object_id) {
  if (object.shape == host::WorldObjectSpec::Shape::cylinder) {
    builder.add_mesh(prism_mesh(0.5 * object.size_x_m, object.height_m, 16),
                     on_floor(object.pose, 0.0), object_id);
  } else {
    builder.add_box(
        on_floor(object.pose, 0.5 * object.height_m),
        Eigen::Vector3d(0.5 * object.size_x_m, 0.5 * object.size_y_m, 0.5 * object.height_m),
        object_id);
  }
}

std::vector<host::WorldObjectSpec> place_clutter(const mrpt::maps::COccupancyGridMap2D& walls,
                                                 const host::ClutterSpec& spec,
                                                 const std::vector<Eigen::Vector2d>& keep_clear,
                                                 double robot_radius_m, std::mt19937_64& rng) {
  std::vector<host::WorldObjectSpec> out;
  if (spec.per_m <= 0.0) return out;
  const int nx = static_cast<int>(walls.getSizeX()), ny = static_cast<int>(walls.getSizeY());
  const double res = walls.getResolution();
  auto is_free = [&](int i, int j) { return in_grid(walls, i, j) && walls.getCell(i, j) > kFree; };
  auto free_at = [&](const Eigen::Vector2d& p) {
    return is_free(walls.x2idx(p.x()), walls.y2idx(p.y()));
  };
  // A wall face is a free cell beside an occupied one; each is about one cell of face, so each
  // takes an object with probability per_m * cell size.
  const double p_cell = std::min(1.0, spec.per_m * res);
  for (int j = 1; j + 1 < ny; ++j) {
    for (int i = 1; i + 1 < nx; ++i) {
      if (!is_free(i, j)) continue;
      Eigen::Vector2d normal = Eigen::Vector2d::Zero();  // away from the wall
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          if ((di || dj) && walls.getCell(i + di, j + dj) < kOccupied)
            normal -= Eigen::Vector2d(di, dj);
        }
      }
      if (normal.squaredNorm() < 0.5) continue;
      if (uniform(rng, 0.0, 1.0) >= p_cell) continue;
      normal.normalize();
      host::WorldObjectSpec o;
      o.shape = uniform(rng, 0.0, 1.0) < 0.5 ? host::WorldObjectSpec::Shape::box
                                             : host::WorldObjectSpec::Shape::cylinder;
      o.size_x_m = uniform(rng, spec.min_size_m, spec.max_size_m);
      o.size_y_m = o.shape == host::WorldObjectSpec::Shape::box
                       ? uniform(rng, spec.min_size_m, spec.max_size_m)
                       : o.size_x_m;
      o.height_m = uniform(rng, spec.min_height_m, spec.max_height_m);
      const double depth_m = o.size_x_m;  // a box faces the room with its x axis
      const Eigen::Vector2d face(walls.idx2x(i), walls.idx2y(j));
      const Eigen::Vector2d centre = face + normal * (0.5 * depth_m + 0.02);
      o.pose = Pose2D{centre.x(), centre.y(), std::atan2(normal.y(), normal.x())};
      // Kept clear of the tour's places.
      const double reach = 0.5 * std::hypot(o.size_x_m, o.size_y_m);
      bool ok = true;
      for (const auto& k : keep_clear) ok &= (k - centre).norm() > spec.keep_clear_m + reach;
      for (const auto& c : out) {
        ok &= (Eigen::Vector2d(c.pose.x_m, c.pose.y_m) - centre).norm() >
              reach + 0.5 * std::hypot(c.size_x_m, c.size_y_m) + 0.1;
      }
      if (!ok) continue;
      // Its footprint on free floor, and the corridor it stands in still wide enough: across
      // from its front to the next wall there is room for the robot and a margin each side.
      const Footprint f = object_footprint(o, "");
      for (double dy = -reach; dy <= reach && ok; dy += 0.5 * res) {
        for (double dx = -reach; dx <= reach && ok; dx += 0.5 * res) {
          const Eigen::Vector2d p = centre + Eigen::Vector2d(dx, dy);
          if (f.distance_m(p) <= 0.0 && !free_at(p)) ok = false;
        }
      }
      const double needed_m = 2.0 * robot_radius_m + 0.6;
      for (double s = 0.0; s <= needed_m && ok; s += 0.5 * res) {
        if (!free_at(centre + normal * (0.5 * depth_m + s))) ok = false;
      }
      if (ok) out.push_back(o);
    }
  }
  return out;
}

namespace {

// A target's extent in its own horizontal axes (its yaw in the map).
struct TargetExtent {
  double yaw_rad = 0.0;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(kInf), hi = -lo;  // in the yawed frame
  double z_min_m = kInf, z_max_m = -kInf;
};

TargetExtent target_extent(const perception::TriangleMesh& mesh,
                           const Eigen::Isometry3d& T_map_model) {
  TargetExtent e;
  const Eigen::Vector3d x_map = T_map_model.linear().col(0);
  e.yaw_rad = std::atan2(x_map.y(), x_map.x());
  const Eigen::Rotation2Dd R_inv(-e.yaw_rad);
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector3d p = T_map_model * v.cast<double>();
    const Eigen::Vector2d q = R_inv * p.head<2>();
    e.lo = e.lo.cwiseMin(q);
    e.hi = e.hi.cwiseMax(q);
    e.z_min_m = std::min(e.z_min_m, p.z());
    e.z_max_m = std::max(e.z_max_m, p.z());
  }
  return e;
}

}  // namespace

std::optional<Footprint> target_footprint(const perception::TriangleMesh& mesh,
                                          const Eigen::Isometry3d& T_map_model,
                                          const std::string& name) {
  if (mesh.vertices.empty()) return std::nullopt;
  const TargetExtent e = target_extent(mesh, T_map_model);
  Footprint f;
  f.shape = Footprint::Shape::rect;
  f.yaw_rad = e.yaw_rad;
  f.centre_m = Eigen::Rotation2Dd(e.yaw_rad) * (0.5 * (e.lo + e.hi));
  f.half_m = 0.5 * (e.hi - e.lo);
  f.z_min_m = e.z_min_m;
  f.z_max_m = e.z_max_m;
  f.name = name;
  return f;
}

std::vector<host::WorldObjectSpec> target_supports(const perception::TriangleMesh& mesh,
                                                   const Eigen::Isometry3d& T_map_model) {
  std::vector<host::WorldObjectSpec> out;
  if (mesh.vertices.empty()) return out;
  const TargetExtent e = target_extent(mesh, T_map_model);
  const double yaw = e.yaw_rad;
  const Eigen::Vector2d lo = e.lo, hi = e.hi;
  const double z_min = e.z_min_m;
  if (z_min < 0.05) return out;
  const Eigen::Rotation2Dd R(yaw);
  const Eigen::Vector2d size = hi - lo;
  const Eigen::Vector2d mid = R * (0.5 * (lo + hi));
  const double height_m = z_min - 0.002;  // just under it: the support is not the target
  if (std::min(size.x(), size.y()) >= 0.05) {
    host::WorldObjectSpec plinth;
    plinth.shape = host::WorldObjectSpec::Shape::box;
    plinth.pose = Pose2D{mid.x(), mid.y(), yaw};
    plinth.size_x_m = 0.8 * size.x();
    plinth.size_y_m = 0.8 * size.y();
    plinth.height_m = height_m;
    out.push_back(plinth);
    return out;
  }
  // A flat target stands on two posts near its ends, along its long side.
  const int long_axis = size.x() >= size.y() ? 0 : 1;
  for (double side : {-0.35, 0.35}) {
    Eigen::Vector2d offset = Eigen::Vector2d::Zero();
    offset[long_axis] = side * size[long_axis];
    const Eigen::Vector2d at = mid + R * offset;
    host::WorldObjectSpec post;
    post.shape = host::WorldObjectSpec::Shape::cylinder;
    post.pose = Pose2D{at.x(), at.y(), 0.0};
    post.size_x_m = post.size_y_m = 0.04;
    post.height_m = height_m;
    out.push_back(post);
  }
  return out;
}

}  // namespace projtour::sim
