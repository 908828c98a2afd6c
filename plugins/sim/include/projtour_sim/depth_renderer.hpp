#pragma once
// Ideal depth rendering by ray casting: a static scene of triangles (target meshes, boxes, walls
// extruded from an occupancy grid) under a BVH, plus an analytic floor plane.
//
// Usage (library `projtour_sim_render`):
//
//   projtour::sim::SceneBuilder builder;
//   builder.add_mesh(projtour::load_mesh("bunny.ply"), T_world_model, /*object_id=*/2);
//   builder.set_floor(0.0, /*object_id=*/0);
//   builder.add_occupancy_walls(grid, 2.0, /*object_id=*/1);   // optional
//   const projtour::sim::Scene scene = builder.build();
//   const projtour::sim::DepthRenderer renderer(intrinsics);    // any PinholeModel
//   projtour::sim::IdealDepth ideal;
//   renderer.render(scene, T_world_camera_optical, ideal);
//   std::mt19937_64 rng(seed);
//   projtour::DepthFrame frame = projtour::sim::apply_kinect_noise(ideal, intrinsics, {}, rng);
//
// Object ids are the caller's: any int >= 0; kNoObject marks a pixel that hit nothing.
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <vector>

#include "projtour/contract/pinhole.hpp"
#include "projtour/perception/model.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour::sim {

constexpr int kNoObject = -1;
// Barycentric slack of the ray-triangle test: float rounding in each triangle's own frame can
// reject a ray through a shared edge or vertex in every triangle that has it, and the ray then
// slips through a closed mesh (a Model Point placed on a vertex was "hit" on the far side).
// Scenes live in map coordinates tens of metres from the origin, where a float resolves ~4 um:
// on a 2 cm triangle that is 2e-4 of its frame, so the slack is 1e-3 (20 um of overlap).
constexpr float kEdgeTolerance = 1e-3f;

struct RayHit {
  float t = std::numeric_limits<float>::infinity();  // ray parameter: origin + t * dir
  int object_id = kNoObject;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit geometric normal, world frame
};

// A person as the sensors meet them: a vertical cylinder (the body, from the floor) under a
// sphere (the head). Intersected analytically: people move every tick, and a BVH cannot.
struct PersonShape {
  Eigen::Vector2f centre_m = Eigen::Vector2f::Zero();
  float radius_m = 0.25f;
  float body_top_m = 1.48f;
  float head_radius_m = 0.11f;
  float head_z_m = 1.59f;
  int object_id = kNoObject;
};

// A scene ready for ray queries (make one with SceneBuilder): immutable triangles and floor,
// plus a moving layer of people set between queries. Cheap to move; queries are const and
// thread-safe (set_people is not: call it only while nobody queries).
class Scene {
 public:
  Scene() = default;

  void set_people(std::vector<PersonShape> people) { people_ = std::move(people); }
  const std::vector<PersonShape>& people() const { return people_; }

  // Closest hit with t in (0, t_max) along origin + t * dir (dir need not be unit). False when
  // nothing is hit.
  bool intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float t_max,
                 RayHit& hit) const;
  // Four rays from one origin at once (SSE where available): what a pinhole camera casts.
  // dir_x/y/z hold the four directions, lane by lane; each hit gets its t_max first.
  void intersect4(const Eigen::Vector3f& origin, const float dir_x[4], const float dir_y[4],
                  const float dir_z[4], float t_max, RayHit hits[4]) const;
  std::size_t triangle_count() const { return tri_object_.size(); }
  bool has_floor() const { return has_floor_; }

 private:
  friend class SceneBuilder;
  struct Node {
    float lo[3];
    std::int32_t first;  // leaf: first triangle; inner: index of the left child (right = +1)
    float hi[3];
    std::int32_t count;  // > 0: leaf with this many triangles
  };
  // Baldwin-Weber transform (rows: barycentric b1, b2, scaled plane distance), one record per
  // triangle in BVH leaf order: fewer operations per test than Moeller-Trumbore.
  struct Tri {
    float m[12];
  };
  void intersect_bvh(const float o[3], const float d[3], RayHit& hit) const;
  void intersect_people(const Eigen::Vector3f& o, const Eigen::Vector3f& d, RayHit& hit) const;
  void intersect_bvh4(const float o[3], const float dx[4], const float dy[4], const float dz[4],
                      RayHit hits[4]) const;

  std::vector<Node> nodes_;
  std::vector<Tri> tris_;
  std::vector<Eigen::Vector3f> tri_normal_;
  std::vector<std::int32_t> tri_object_;
  bool has_floor_ = false;
  float floor_z_m_ = 0.0f;
  int floor_object_ = kNoObject;
  std::vector<PersonShape> people_;
};

class SceneBuilder {
 public:
  // A triangle mesh in its own frame, placed at T_world_mesh.
  void add_mesh(const perception::TriangleMesh& mesh, const Eigen::Isometry3d& T_world_mesh,
                int object_id);
  // An oriented box centred at T_world_box's origin, axes along its rotation.
  void add_box(const Eigen::Isometry3d& T_world_box, const Eigen::Vector3d& half_extents_m,
               int object_id);
  // The infinite horizontal plane z = z_m (seen from both sides), intersected analytically.
  void set_floor(double z_m, int object_id);
  // Occupied cells of the grid (occupancy > 0.5) merged greedily into rectangles and extruded
  // from z = 0 up to height_m. Returns the number of boxes added.
  std::size_t add_occupancy_walls(const mrpt::maps::COccupancyGridMap2D& map, double height_m,
                                  int object_id);

  std::size_t triangle_count() const { return objects_.size(); }
  // Builds the BVH (binned SAH). The builder stays usable.
  Scene build() const;

 private:
  void add_triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                    int object_id);

  std::vector<Eigen::Vector3f> corners_;  // three per triangle
  std::vector<std::int32_t> objects_;
  bool has_floor_ = false;
  double floor_z_m_ = 0.0;
  int floor_object_ = kNoObject;
};

// One ideal (noise-free) depth image with what each pixel saw.
struct IdealDepth {
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;           // along the optical z axis; 0 = nothing within range
  std::vector<std::int32_t> object_id;  // kNoObject where nothing was hit
  std::vector<float> cos_incidence;     // |cos| of the angle between ray and surface normal
  std::vector<Eigen::Vector3f> normal;  // unit world-frame normal facing the camera; 0 if none

  float depth_at(int u, int v) const { return depth_m[static_cast<std::size_t>(v) * width + u]; }
  int object_at(int u, int v) const { return object_id[static_cast<std::size_t>(v) * width + u]; }
};

// Casts one ray per pixel centre. Ray directions (distortion removed) are computed once here,
// so keep one renderer per intrinsics.
class DepthRenderer {
 public:
  explicit DepthRenderer(const PinholeModel& intrinsics);
  const PinholeModel& intrinsics() const { return intrinsics_; }
  // Per pixel (row-major), the optical-frame ray with z = 1: a hit at depth z lies at ray * z.
  const std::vector<Eigen::Vector3f>& rays() const { return rays_; }

  // T_world_camera is the OPTICAL frame (z forward, x right, y down). Surfaces deeper than
  // max_depth_m are not looked for (a cheap cut-off: the Kinect sees nothing past 4 m anyway).
  // `out` is resized on first use and reused after (no per-frame allocation).
  void render(const Scene& scene, const Eigen::Isometry3d& T_world_camera, IdealDepth& out,
              double max_depth_m = std::numeric_limits<double>::infinity()) const;

 private:
  PinholeModel intrinsics_;
  std::vector<Eigen::Vector3f> rays_;  // per pixel, optical frame, z = 1
};

}  // namespace projtour::sim
