// Scene building (meshes, boxes, occupancy walls), the binned-SAH BVH and ray queries.
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kBins = 16;
constexpr int kMaxLeafSize = 4;
constexpr int kStackSize = 64;
constexpr float kBoxPadding = 1e-4f;  // metres

struct Box3 {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(kInf);
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(-kInf);
  void grow(const Eigen::Vector3f& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Box3& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  float area() const {
    if (lo.x() > hi.x()) return 0.0f;
    const Eigen::Vector3f e = hi - lo;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }
};

// Entry distance of the ray into the box, or infinity when it misses it or enters beyond t_max.
// Branch-free slabs with the origin pre-scaled (o_inv = o * inv_d): the traversal's hot spot.
inline float slab_entry(const float lo[3], const float hi[3], const float inv_d[3],
                        const float o_inv[3], float t_max) {
  const float tx0 = lo[0] * inv_d[0] - o_inv[0], tx1 = hi[0] * inv_d[0] - o_inv[0];
  const float ty0 = lo[1] * inv_d[1] - o_inv[1], ty1 = hi[1] * inv_d[1] - o_inv[1];
  const float tz0 = lo[2] * inv_d[2] - o_inv[2], tz1 = hi[2] * inv_d[2] - o_inv[2];
  const float t0 = std::max(std::max(std::min(tx0, tx1), std::min(ty0, ty1)),
                            std::max(std::min(tz0, tz1), 0.0f));
  const float t1 = std::min(std::min(std::max(tx0, tx1), std::max(ty0, ty1)),
                            std::min(std::max(tz0, tz1), t_max));
  return t0 <= t1 ? t0 : kInf;
}

// The best split of triangles order[first, first + count) by binned SAH over the centroid
// bounds: the axis (-1 when no split beats a leaf) and the last bin on the left.
struct SahSplit {
  int axis = -1;
  int bin = 0;
};
SahSplit best_sah_split(const std::vector<Box3>& tri_box,
                        const std::vector<Eigen::Vector3f>& centroid,
                        const std::vector<std::int32_t>& order, std::int32_t first,
                        std::int32_t count, const Box3& bounds, const Box3& cbounds) {
  int best_axis = -1, best_split = 0;
  float best_cost = static_cast<float>(count) * bounds.area();
  for (int a = 0; a < 3; ++a) {
    const float extent = cbounds.hi[a] - cbounds.lo[a];
    if (extent <= 0.0f) continue;
    std::array<Box3, kBins> bin_box;
    std::array<int, kBins> bin_count{};
    const float scale = kBins / extent;
    for (std::int32_t k = first; k < first + count; ++k) {
      const int b =
          std::min(kBins - 1, static_cast<int>((centroid[order[k]][a] - cbounds.lo[a]) * scale));
      ++bin_count[b];
      bin_box[b].grow(tri_box[order[k]]);
    }
    std::array<float, kBins> right_area{};
    std::array<int, kBins> right_count{};
    Box3 acc;
    int cnt = 0;
    for (int b = kBins - 1; b > 0; --b) {
      acc.grow(bin_box[b]);
      cnt += bin_count[b];
      right_area[b] = acc.area();
      right_count[b] = cnt;
    }
    acc = Box3();
    cnt = 0;
    for (int b = 0; b < kBins - 1; ++b) {
      acc.grow(bin_box[b]);
      cnt += bin_count[b];
      const float cost = cnt * acc.area() + right_count[b + 1] * right_area[b + 1];
      if (cnt > 0 && right_count[b + 1] > 0 && cost < best_cost) {
        best_cost = cost;
        best_axis = a;
        best_split = b;
      }
    }
  }
  return {best_axis, best_split};
}

// A triangle's rows for the ray test, from its first corner `a` and its edges e1, e2.
void triangle_rows(const Eigen::Vector3f& a, const Eigen::Vector3f& e1, const Eigen::Vector3f& e2,
                   float* m) {
  const Eigen::Vector3f n = e1.cross(e2);
  int axis;
  n.cwiseAbs().maxCoeff(&axis);
  const int i1 = (axis + 1) % 3, i2 = (axis + 2) % 3;
  const float inv = 1.0f / n[axis];
  // Rows as in Baldwin & Weber (JCGT 2016), written for any dominant axis. Their constant
  // terms come from c x a and b x a, which cancel catastrophically in float for a small
  // triangle tens of metres from the origin (b1 off by ~0.4: rays slipped through meshes);
  // instead each row is anchored at a, where both barycentrics are 0, in double.
  m[axis] = 0.0f;
  m[i1] = e2[i2] * inv;
  m[i2] = -e2[i1] * inv;
  m[4 + axis] = 0.0f;
  m[4 + i1] = -e1[i2] * inv;
  m[4 + i2] = e1[i1] * inv;
  const Eigen::Vector3d a_d = a.cast<double>();
  m[3] = static_cast<float>(
      -(double{m[0]} * a_d.x() + double{m[1]} * a_d.y() + double{m[2]} * a_d.z()));
  m[7] = static_cast<float>(
      -(double{m[4]} * a_d.x() + double{m[5]} * a_d.y() + double{m[6]} * a_d.z()));
  m[8 + axis] = 1.0f;
  m[8 + i1] = n[i1] * inv;
  m[8 + i2] = n[i2] * inv;
  m[11] = -n.dot(a) * inv;
}

}  // namespace

void SceneBuilder::add_triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                const Eigen::Vector3f& c, int object_id) {
  // Degenerate triangles can never be hit and only slow the BVH down.
  if ((b - a).cross(c - a).squaredNorm() <= 0.0f) return;
  corners_.push_back(a);
  corners_.push_back(b);
  corners_.push_back(c);
  objects_.push_back(object_id);
}

void SceneBuilder::add_mesh(const perception::TriangleMesh& mesh,
                            const Eigen::Isometry3d& T_world_mesh, int object_id) {
  const Eigen::Isometry3f T = T_world_mesh.cast<float>();
  std::vector<Eigen::Vector3f> world(mesh.vertices.size());
  for (std::size_t i = 0; i < world.size(); ++i) {
    world[i] = T * mesh.vertices[i];
    // A NaN corner poisons the BVH's bounds and the traversal reads past its nodes (SIGSEGV):
    // the run's checks refuse such a model first, and this stops any other way in.
    if (!world[i].allFinite()) {
      throw std::invalid_argument("mesh vertex " + std::to_string(i) + " is not finite");
    }
  }
  corners_.reserve(corners_.size() + 3 * mesh.triangles.size());
  const int vertex_count = static_cast<int>(world.size());
  for (const Eigen::Vector3i& f : mesh.triangles) {
    if ((f.array() < 0).any() || (f.array() >= vertex_count).any()) {
      throw std::invalid_argument("mesh triangle index out of range");
    }
    add_triangle(world[f[0]], world[f[1]], world[f[2]], object_id);
  }
}

void SceneBuilder::add_box(const Eigen::Isometry3d& T_world_box,
                           const Eigen::Vector3d& half_extents_m, int object_id) {
  std::array<Eigen::Vector3f, 8> c;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d local((i & 1) ? half_extents_m.x() : -half_extents_m.x(),
                                (i & 2) ? half_extents_m.y() : -half_extents_m.y(),
                                (i & 4) ? half_extents_m.z() : -half_extents_m.z());
    c[i] = (T_world_box * local).cast<float>();
  }
  // Each face as two triangles wound outward (normals are two-sided for rendering anyway).
  static const int kFaces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                   {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : kFaces) {
    add_triangle(c[f[0]], c[f[1]], c[f[2]], object_id);
    add_triangle(c[f[0]], c[f[2]], c[f[3]], object_id);
  }
}

void SceneBuilder::set_floor(double z_m, int object_id) {
  has_floor_ = true;
  floor_z_m_ = z_m;
  floor_object_ = object_id;
}

std::size_t SceneBuilder::add_occupancy_walls(const mrpt::maps::COccupancyGridMap2D& map,
                                              double height_m, int object_id) {
  const int nx = static_cast<int>(map.getSizeX());
  const int ny = static_cast<int>(map.getSizeY());
  const double res = map.getResolution();
  std::vector<char> todo(static_cast<std::size_t>(nx) * ny, 0);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i)
      todo[static_cast<std::size_t>(j) * nx + i] = map.getCell(i, j) < 0.5f;
  }
  auto occupied = [&](int i, int j) { return todo[static_cast<std::size_t>(j) * nx + i] != 0; };
  // Greedy rectangles: extend a run along x, then grow it along y while the whole run is still
  // occupied. A wall of many cells becomes one box of 10 triangles.
  std::size_t boxes = 0;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      if (!occupied(i, j)) continue;
      int i_end = i + 1;
      while (i_end < nx && occupied(i_end, j)) ++i_end;
      int j_end = j + 1;
      while (j_end < ny) {
        bool full = true;
        for (int k = i; k < i_end && full; ++k) full = occupied(k, j_end);
        if (!full) break;
        ++j_end;
      }
      for (int jj = j; jj < j_end; ++jj) {
        std::fill_n(todo.begin() + static_cast<std::ptrdiff_t>(jj) * nx + i, i_end - i, 0);
      }
      const double x0 = map.idx2x(i) - 0.5 * res, x1 = map.idx2x(i_end - 1) + 0.5 * res;
      const double y0 = map.idx2y(j) - 0.5 * res, y1 = map.idx2y(j_end - 1) + 0.5 * res;
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * height_m);
      add_box(T, Eigen::Vector3d(0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.5 * height_m), object_id);
      ++boxes;
    }
  }
  return boxes;
}

Scene SceneBuilder::build() const {
  Scene scene;
  scene.has_floor_ = has_floor_;
  scene.floor_z_m_ = static_cast<float>(floor_z_m_);
  scene.floor_object_ = floor_object_;
  const std::size_t n = objects_.size();
  if (n == 0) return scene;

  std::vector<Box3> tri_box(n);
  std::vector<Eigen::Vector3f> centroid(n);
  for (std::size_t t = 0; t < n; ++t) {
    for (int k = 0; k < 3; ++k) tri_box[t].grow(corners_[3 * t + k]);
    centroid[t] = (corners_[3 * t] + corners_[3 * t + 1] + corners_[3 * t + 2]) / 3.0f;
  }
  std::vector<std::int32_t> order(n);
  std::iota(order.begin(), order.end(), 0);

  struct Pending {
    std::int32_t node, first, count;
  };
  std::vector<Scene::Node>& nodes = scene.nodes_;
  nodes.reserve(2 * n / kMaxLeafSize + 1);
  nodes.push_back({});
  std::vector<Pending> work{{0, 0, static_cast<std::int32_t>(n)}};
  while (!work.empty()) {
    const Pending job = work.back();
    work.pop_back();
    Box3 bounds, cbounds;
    for (std::int32_t k = job.first; k < job.first + job.count; ++k) {
      bounds.grow(tri_box[order[k]]);
      cbounds.grow(centroid[order[k]]);
    }
    Scene::Node& node = nodes[job.node];
    // Padded: a ray meeting a triangle exactly on its box's face (a vertex on a ring of a
    // cylinder, a flat face) is otherwise culled by the slab test's rounding in some boxes and
    // found in none, and the ray slips through to the far side.
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = bounds.lo[a] - kBoxPadding;
      node.hi[a] = bounds.hi[a] + kBoxPadding;
    }
    node.first = job.first;
    node.count = job.count;
    if (job.count <= kMaxLeafSize) continue;

    // Binned SAH over the centroid bounds.
    const SahSplit split =
        best_sah_split(tri_box, centroid, order, job.first, job.count, bounds, cbounds);
    const int best_axis = split.axis, best_split = split.bin;
    std::int32_t mid;
    if (best_axis >= 0) {
      const float lo = cbounds.lo[best_axis];
      const float scale = kBins / (cbounds.hi[best_axis] - lo);
      mid = static_cast<std::int32_t>(
          std::partition(order.begin() + job.first, order.begin() + job.first + job.count,
                         [&](std::int32_t t) {
                           return std::min(kBins - 1, static_cast<int>(
                                                          (centroid[t][best_axis] - lo) * scale)) <=
                                  best_split;
                         }) -
          order.begin());
    } else {
      // No split beats a leaf by SAH; still cap leaf size with a median split on the widest axis.
      int axis;
      (cbounds.hi - cbounds.lo).maxCoeff(&axis);
      mid = job.first + job.count / 2;
      std::nth_element(
          order.begin() + job.first, order.begin() + mid, order.begin() + job.first + job.count,
          [&](std::int32_t x, std::int32_t y) { return centroid[x][axis] < centroid[y][axis]; });
    }
    const std::int32_t left = static_cast<std::int32_t>(nodes.size());
    nodes[job.node].first = left;
    nodes[job.node].count = 0;
    nodes.push_back({});
    nodes.push_back({});
    work.push_back({left, job.first, mid - job.first});
    work.push_back({left + 1, mid, job.first + job.count - mid});
  }

  scene.tris_.resize(n);
  scene.tri_normal_.resize(n);
  scene.tri_object_.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t t = static_cast<std::size_t>(order[k]);
    const Eigen::Vector3f& a = corners_[3 * t];
    const Eigen::Vector3f e1 = corners_[3 * t + 1] - a;
    const Eigen::Vector3f e2 = corners_[3 * t + 2] - a;
    triangle_rows(a, e1, e2, scene.tris_[k].m);
    scene.tri_normal_[k] = e1.cross(e2).normalized();
    scene.tri_object_[k] = objects_[t];
  }
  return scene;
}

void Scene::intersect_bvh(const float o[3], const float d[3], RayHit& hit) const {
  // Axis-parallel rays would make 0 * inf = NaN in the slabs; nudge them off the axis.
  auto safe_inverse = [](float x) {
    return 1.0f / (std::fabs(x) > 1e-20f ? x : std::copysign(1e-20f, x));
  };
  const float inv_d[3] = {safe_inverse(d[0]), safe_inverse(d[1]), safe_inverse(d[2])};
  const float o_inv[3] = {o[0] * inv_d[0], o[1] * inv_d[1], o[2] * inv_d[2]};
  std::int32_t stack[kStackSize];
  float stack_t[kStackSize];
  int top = 0;
  std::int32_t best = -1;
  float t_best = hit.t;
  if (slab_entry(nodes_[0].lo, nodes_[0].hi, inv_d, o_inv, t_best) == kInf) return;
  std::int32_t current = 0;
  while (true) {
    const Node& node = nodes_[current];
    if (node.count > 0) {
      for (std::int32_t k = node.first; k < node.first + node.count; ++k) {
        // Baldwin-Weber: the triangle's affine frame maps the hit to (b1, b2, distance).
        const float* m = tris_[k].m;
        const float dz = m[8] * d[0] + m[9] * d[1] + m[10] * d[2];
        const float oz = m[8] * o[0] + m[9] * o[1] + m[10] * o[2] + m[11];
        const float t = -oz / dz;
        if (!(t > 1e-6f && t < t_best)) continue;
        const float h[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
        const float b1 = m[0] * h[0] + m[1] * h[1] + m[2] * h[2] + m[3];
        if (b1 < -kEdgeTolerance || b1 > 1.0f + kEdgeTolerance) continue;
        const float b2 = m[4] * h[0] + m[5] * h[1] + m[6] * h[2] + m[7];
        if (b2 < -kEdgeTolerance || b1 + b2 > 1.0f + kEdgeTolerance) continue;
        {
          t_best = t;
          best = k;
        }
      }
    } else {
      std::int32_t near_child = node.first, far_child = node.first + 1;
      float t_near = slab_entry(nodes_[near_child].lo, nodes_[near_child].hi, inv_d, o_inv, t_best);
      float t_far = slab_entry(nodes_[far_child].lo, nodes_[far_child].hi, inv_d, o_inv, t_best);
      if (t_far < t_near) {
        std::swap(t_near, t_far);
        std::swap(near_child, far_child);
      }
      if (t_near != kInf) {
        if (t_far != kInf && top < kStackSize) {
          stack_t[top] = t_far;
          stack[top++] = far_child;
        }
        current = near_child;
        continue;
      }
    }
    // Pop the next subtree still worth visiting (its box may now lie beyond the best hit).
    bool found = false;
    while (top > 0) {
      --top;
      if (stack_t[top] < t_best) {
        current = stack[top];
        found = true;
        break;
      }
    }
    if (!found) break;
  }
  if (best >= 0) {
    hit.t = t_best;
    hit.object_id = tri_object_[best];
    hit.normal = tri_normal_[best];
  }
}

bool Scene::intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float t_max,
                      RayHit& hit) const {
  hit = RayHit();
  hit.t = t_max;
  if (has_floor_ && dir.z() != 0.0f) {
    const float t = (floor_z_m_ - origin.z()) / dir.z();
    if (t > 1e-6f && t < hit.t) {
      hit.t = t;
      hit.object_id = floor_object_;
      hit.normal = Eigen::Vector3f::UnitZ();
    }
  }
  if (!nodes_.empty()) intersect_bvh(origin.data(), dir.data(), hit);
  if (!people_.empty()) intersect_people(origin, dir, hit);
  if (hit.object_id == kNoObject) {
    hit.t = std::numeric_limits<float>::infinity();
    return false;
  }
  return true;
}

void Scene::intersect_people(const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                             RayHit& hit) const {
  const float a = d.x() * d.x() + d.y() * d.y();
  for (const PersonShape& p : people_) {
    // Body: the side of the cylinder, then its top disk.
    const float ox = o.x() - p.centre_m.x(), oy = o.y() - p.centre_m.y();
    const float r2 = p.radius_m * p.radius_m;
    if (a > 1e-12f) {
      const float b = ox * d.x() + oy * d.y();
      const float c = ox * ox + oy * oy - r2;
      const float disc = b * b - a * c;
      // The head lies within the body's circle seen from above: a ray that misses the circle,
      // or starts outside it going away, misses the person.
      if (disc < 0.0f || (c > 0.0f && b > 0.0f)) continue;
      {
        const float t = (-b - std::sqrt(disc)) / a;  // the near side; from inside, none
        const float z = o.z() + t * d.z();
        if (t > 1e-6f && t < hit.t && z >= 0.0f && z <= p.body_top_m) {
          hit.t = t;
          hit.object_id = p.object_id;
          hit.normal = Eigen::Vector3f(ox + t * d.x(), oy + t * d.y(), 0.0f) / p.radius_m;
        }
      }
    }
    if (d.z() != 0.0f) {
      const float t = (p.body_top_m - o.z()) / d.z();
      const float x = ox + t * d.x(), y = oy + t * d.y();
      if (t > 1e-6f && t < hit.t && x * x + y * y <= r2) {
        hit.t = t;
        hit.object_id = p.object_id;
        hit.normal = Eigen::Vector3f::UnitZ();
      }
    }
    // Head.
    const Eigen::Vector3f oc = o - Eigen::Vector3f(p.centre_m.x(), p.centre_m.y(), p.head_z_m);
    const float aa = d.squaredNorm(), bb = oc.dot(d);
    const float disc = bb * bb - aa * (oc.squaredNorm() - p.head_radius_m * p.head_radius_m);
    if (disc >= 0.0f) {
      const float t = (-bb - std::sqrt(disc)) / aa;
      if (t > 1e-6f && t < hit.t) {
        hit.t = t;
        hit.object_id = p.object_id;
        hit.normal = (oc + t * d) / p.head_radius_m;
      }
    }
  }
}

}  // namespace projtour::sim
