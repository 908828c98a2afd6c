#pragma once
// A mesh made ready to stand in a building (centred, scaled to metres) and the content areas the
// generator draws on its front: four Model Points on the surface the +x side sees.
#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <optional>
#include <random>
#include <vector>

#include "projtour/perception/model.hpp"

namespace projtour::ground {

// The mesh with its vertex centroid at the origin, its largest extent `size_m` (when given).
perception::TriangleMesh centred(perception::TriangleMesh mesh, std::optional<double> size_m);

// Writes an OFF file (what perception::load_mesh reads back).
void write_off(const perception::TriangleMesh& mesh, const std::filesystem::path& file);

struct MeshBounds {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
};
MeshBounds bounds_of(const perception::TriangleMesh& mesh);

// The first surface a ray along -x meets at (y, z) of the model frame, seen from +x.
struct FrontHit {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double normal_x = 0.0;  // |n.x| of the triangle hit: 1 faces the viewer, 0 is edge-on
};

// Triangles are binned by their extent in y-z (a 64 x 64 grid over the mesh's bounds), so a ray
// looks only at the triangles of its bin.
class FrontSurface {
 public:
  explicit FrontSurface(const perception::TriangleMesh& mesh);
  std::optional<FrontHit> hit(double y_m, double z_m) const;
  const MeshBounds& bounds() const { return bounds_; }

 private:
  static constexpr int kBins = 64;
  int bin_of(double v, double lo, double hi) const;
  const perception::TriangleMesh& mesh_;
  MeshBounds bounds_;
  std::vector<std::vector<int>> bins_;  // kBins * kBins lists of triangle indices
};

// A square content area of side `side_m` (top-left, top-right, bottom-right, bottom-left as seen
// from the front, as a mission writes them) whose corners and centre all land on surface that
// faces the front, or nullopt after `tries` draws.
std::optional<std::array<Eigen::Vector3d, 4>> draw_content_area(const FrontSurface& surface,
                                                                double side_m, std::mt19937_64& rng,
                                                                int tries = 200);

}  // namespace projtour::ground
