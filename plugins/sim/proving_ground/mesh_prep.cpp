#include "mesh_prep.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace projtour::ground {

perception::TriangleMesh centred(perception::TriangleMesh mesh, std::optional<double> size_m) {
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const auto& v : mesh.vertices) centroid += v;
  centroid /= static_cast<float>(mesh.vertices.size());
  for (auto& v : mesh.vertices) v -= centroid;
  if (size_m) {
    const MeshBounds b = bounds_of(mesh);
    const double extent = (b.max - b.min).maxCoeff();
    if (!(extent > 0.0)) throw std::runtime_error("a mesh without extent");
    const float scale = static_cast<float>(*size_m / extent);
    for (auto& v : mesh.vertices) v *= scale;
  }
  return mesh;
}

void write_off(const perception::TriangleMesh& mesh, const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error(file.string() + ": cannot write");
  out << "OFF\n" << mesh.vertices.size() << " " << mesh.triangles.size() << " 0\n";
  out.precision(7);
  for (const auto& v : mesh.vertices) out << v.x() << " " << v.y() << " " << v.z() << "\n";
  for (const auto& t : mesh.triangles) out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
  if (!out) throw std::runtime_error(file.string() + ": write failed");
}

MeshBounds bounds_of(const perception::TriangleMesh& mesh) {
  MeshBounds b;
  b.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  b.max = -b.min;
  for (const auto& v : mesh.vertices) {
    b.min = b.min.cwiseMin(v.cast<double>());
    b.max = b.max.cwiseMax(v.cast<double>());
  }
  return b;
}

FrontSurface::FrontSurface(const perception::TriangleMesh& mesh)
    : mesh_(mesh), bounds_(bounds_of(mesh)), bins_(kBins * kBins) {
  for (std::size_t i = 0; i < mesh_.triangles.size(); ++i) {
    const auto& t = mesh_.triangles[i];
    double y0 = mesh_.vertices[t[0]].y(), y1 = y0, z0 = mesh_.vertices[t[0]].z(), z1 = z0;
    for (int k = 1; k < 3; ++k) {
      y0 = std::min<double>(y0, mesh_.vertices[t[k]].y());
      y1 = std::max<double>(y1, mesh_.vertices[t[k]].y());
      z0 = std::min<double>(z0, mesh_.vertices[t[k]].z());
      z1 = std::max<double>(z1, mesh_.vertices[t[k]].z());
    }
    const int by0 = bin_of(y0, bounds_.min.y(), bounds_.max.y());
    const int by1 = bin_of(y1, bounds_.min.y(), bounds_.max.y());
    const int bz0 = bin_of(z0, bounds_.min.z(), bounds_.max.z());
    const int bz1 = bin_of(z1, bounds_.min.z(), bounds_.max.z());
    for (int by = by0; by <= by1; ++by) {
      for (int bz = bz0; bz <= bz1; ++bz) bins_[by * kBins + bz].push_back(static_cast<int>(i));
    }
  }
}

int FrontSurface::bin_of(double v, double lo, double hi) const {
  if (!(hi > lo)) return 0;
  return std::clamp(static_cast<int>((v - lo) / (hi - lo) * kBins), 0, kBins - 1);
}

std::optional<FrontHit> FrontSurface::hit(double y_m, double z_m) const {
  std::optional<FrontHit> best;
  const int by = bin_of(y_m, bounds_.min.y(), bounds_.max.y());
  const int bz = bin_of(z_m, bounds_.min.z(), bounds_.max.z());
  for (const int i : bins_[by * kBins + bz]) {
    const auto& t = mesh_.triangles[static_cast<std::size_t>(i)];
    const Eigen::Vector3d a = mesh_.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh_.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh_.vertices[t[2]].cast<double>();
    // Barycentric coordinates of (y, z) in the triangle projected on the y-z plane.
    const double d = (b.y() - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (b.z() - a.z());
    if (std::abs(d) < 1e-15) continue;
    const double u = ((y_m - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (z_m - a.z())) / d;
    const double v = ((b.y() - a.y()) * (z_m - a.z()) - (y_m - a.y()) * (b.z() - a.z())) / d;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) continue;
    const Eigen::Vector3d p = a + u * (b - a) + v * (c - a);
    if (best && p.x() <= best->point.x()) continue;
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    best = FrontHit{p, std::abs(n.x())};
  }
  return best;
}

std::optional<std::array<Eigen::Vector3d, 4>> draw_content_area(const FrontSurface& surface,
                                                                double side_m, std::mt19937_64& rng,
                                                                int tries) {
  const MeshBounds& b = surface.bounds();
  const double half = side_m / 2.0;
  if (b.max.y() - b.min.y() < side_m || b.max.z() - b.min.z() < side_m) return std::nullopt;
  std::uniform_real_distribution<double> y_of(b.min.y() + half, b.max.y() - half);
  std::uniform_real_distribution<double> z_of(b.min.z() + half, b.max.z() - half);
  // Faces within ~70 degrees of the viewer only: a corner on a grazing slope is where light
  // lands smeared, and no advertiser would choose it.
  constexpr double kMinNormalX = 0.35;
  for (int i = 0; i < tries; ++i) {
    const double yc = y_of(rng), zc = z_of(rng);
    const std::array<Eigen::Vector2d, 5> at = {
        Eigen::Vector2d(yc - half, zc + half), Eigen::Vector2d(yc + half, zc + half),
        Eigen::Vector2d(yc + half, zc - half), Eigen::Vector2d(yc - half, zc - half),
        Eigen::Vector2d(yc, zc)};
    std::array<Eigen::Vector3d, 5> hits;
    bool ok = true;
    for (std::size_t k = 0; k < at.size() && ok; ++k) {
      const auto h = surface.hit(at[k].x(), at[k].y());
      ok = h && h->normal_x >= kMinNormalX;
      if (ok) hits[k] = h->point;
    }
    if (!ok) continue;
    // The area must read as one surface from the front: its corners within half a side of each
    // other in depth (not the nose and the cheek behind it).
    double x_min = hits[0].x(), x_max = hits[0].x();
    for (const auto& p : hits) {
      x_min = std::min(x_min, p.x());
      x_max = std::max(x_max, p.x());
    }
    if (x_max - x_min > half) continue;
    return std::array<Eigen::Vector3d, 4>{hits[0], hits[1], hits[2], hits[3]};
  }
  return std::nullopt;
}

}  // namespace projtour::ground
