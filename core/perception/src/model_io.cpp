// Target models: mesh loading (PLY via PCL, OFF by hand), area-weighted surface sampling and
// normals for point-cloud models (pcl::NormalEstimation over a kd-tree).
#include <pcl/PCLPointCloud2.h>
#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/features/normal_3d.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

#include "projtour/perception/model.hpp"

namespace projtour::perception {
namespace {

std::string lower_extension(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
  throw std::runtime_error(file.string() + ": " + what);
}

// Polygons with more than three corners become fans.
void add_polygon(const std::vector<int>& corners, int vertex_count, TriangleMesh& mesh,
                 const std::filesystem::path& file) {
  for (int index : corners) {
    if (index < 0 || index >= vertex_count) fail(file, "face index out of range");
  }
  for (std::size_t i = 2; i < corners.size(); ++i) {
    mesh.triangles.emplace_back(corners[0], corners[i - 1], corners[i]);
  }
}

// Reads the next token, skipping '#' comments (OFF allows them anywhere).
bool next_token(std::istream& in, std::string& token) {
  while (in >> token) {
    if (token[0] != '#') return true;
    std::string rest;
    std::getline(in, rest);
  }
  return false;
}

TriangleMesh load_off(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) fail(file, "cannot open");
  std::string token;
  if (!next_token(in, token) || token.compare(token.size() >= 3 ? token.size() - 3 : 0, 3, "OFF")) {
    fail(file, "not an OFF file (no OFF header)");
  }
  // "COFF", "NOFF" and the like carry extra per-vertex numbers; only the plain and C variants
  // are accepted so vertex parsing stays simple.
  const bool coloured = token == "COFF";
  if (token != "OFF" && !coloured) fail(file, "unsupported OFF variant " + token);
  auto read_int = [&](const char* what) {
    if (!next_token(in, token)) fail(file, std::string("truncated: expected ") + what);
    try {
      return std::stoi(token);
    } catch (const std::exception&) {
      fail(file, std::string("expected ") + what + ", got '" + token + "'");
    }
  };
  auto read_float = [&]() {
    if (!next_token(in, token)) fail(file, "truncated vertex list");
    try {
      return std::stof(token);
    } catch (const std::exception&) {
      fail(file, "expected a number, got '" + token + "'");
    }
  };
  const int vertex_count = read_int("vertex count");
  const int face_count = read_int("face count");
  read_int("edge count");
  if (vertex_count < 0 || face_count < 0) fail(file, "negative element count");
  TriangleMesh mesh;
  mesh.vertices.reserve(static_cast<std::size_t>(vertex_count));
  for (int i = 0; i < vertex_count; ++i) {
    const float x = read_float(), y = read_float(), z = read_float();
    mesh.vertices.emplace_back(x, y, z);
    if (coloured) {
      for (int c = 0; c < 4; ++c) read_float();
    }
  }
  std::vector<int> corners;
  for (int f = 0; f < face_count; ++f) {
    const int n = read_int("face corner count");
    if (n < 0) fail(file, "negative face corner count");
    corners.resize(static_cast<std::size_t>(n));
    for (int& c : corners) c = read_int("face index");
    // Trailing per-face colours sit on the same line; skip them.
    std::string rest;
    std::getline(in, rest);
    add_polygon(corners, vertex_count, mesh, file);
  }
  return mesh;
}

// PLY through PCL: the vertices as XYZ and the polygons, if any.
void read_ply(const std::filesystem::path& file, pcl::PolygonMesh& out) {
  if (!std::filesystem::exists(file)) fail(file, "no such file");
  pcl::PLYReader reader;
  if (reader.read(file.string(), out) < 0) fail(file, "cannot read as PLY");
}

std::vector<Eigen::Vector3f> xyz_of(const pcl::PCLPointCloud2& cloud) {
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2(cloud, xyz);
  std::vector<Eigen::Vector3f> points;
  points.reserve(xyz.size());
  for (const auto& p : xyz.points) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      points.emplace_back(p.x, p.y, p.z);
    }
  }
  return points;
}

TriangleMesh mesh_from_pcl(const pcl::PolygonMesh& pm, const std::filesystem::path& file) {
  TriangleMesh mesh;
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2(pm.cloud, xyz);
  mesh.vertices.reserve(xyz.size());
  for (const auto& p : xyz.points) mesh.vertices.emplace_back(p.x, p.y, p.z);
  std::vector<int> corners;
  for (const auto& polygon : pm.polygons) {
    corners.assign(polygon.vertices.begin(), polygon.vertices.end());
    add_polygon(corners, static_cast<int>(mesh.vertices.size()), mesh, file);
  }
  return mesh;
}

// Uniform [0, 1) from the raw engine output: std::uniform_real_distribution is not specified
// bit-for-bit across standard libraries, and sampling must be reproducible.
double unit(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

float bounding_radius(const std::vector<Eigen::Vector3f>& points) {
  float r2 = 0.0f;
  for (const auto& p : points) r2 = std::max(r2, p.squaredNorm());
  return std::sqrt(r2);
}

// PCA normals over the k nearest neighbours, oriented away from the centroid (target models are
// roughly star-shaped about their origin, and the robot only ever sees their outside). The
// single-threaded estimator and a FLANN kd-tree give the same normals bit for bit on every run;
// NormalEstimationOMP would too only with one thread, so it buys nothing here.
std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3f>& points) {
  // 16 neighbours span a few sample spacings on any density: enough to average out sampling
  // noise, few enough to stay on one side of the thin parts (ears, sign edges).
  constexpr int kNeighbours = 16;
  std::vector<Eigen::Vector3f> normals(points.size(), Eigen::Vector3f::UnitZ());
  if (points.size() < 3) return normals;
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) {
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    centroid += p.cast<double>();
  }
  centroid /= static_cast<double>(points.size());
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimator;
  estimator.setInputCloud(cloud);
  estimator.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setKSearch(std::min<int>(kNeighbours, static_cast<int>(points.size())));
  pcl::PointCloud<pcl::Normal> estimated;
  estimator.compute(estimated);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const pcl::Normal& e = estimated[i];
    Eigen::Vector3f n(e.normal_x, e.normal_y, e.normal_z);
    // Degenerate neighbourhoods (all points on a line) come back as NaN: keep the default.
    if (!n.allFinite() || n.squaredNorm() == 0.0f) continue;
    if (n.cast<double>().dot(points[i].cast<double>() - centroid) < 0.0) n = -n;
    normals[i] = n.normalized();
  }
  return normals;
}

}  // namespace

TriangleMesh load_mesh(const std::filesystem::path& file) {
  const std::string ext = lower_extension(file);
  TriangleMesh mesh;
  if (ext == ".off") {
    mesh = load_off(file);
  } else if (ext == ".ply") {
    pcl::PolygonMesh pm;
    read_ply(file, pm);
    mesh = mesh_from_pcl(pm, file);
  } else {
    fail(file, "unsupported mesh format '" + ext + "' (expected .ply or .off)");
  }
  if (mesh.triangles.empty()) fail(file, "holds no triangles");
  return mesh;
}

ModelCloud sample_mesh(const TriangleMesh& mesh, double spacing_m, unsigned seed) {
  if (!(spacing_m > 0.0)) throw std::invalid_argument("sample_mesh: spacing_m must be > 0");
  const std::size_t n_tri = mesh.triangles.size();
  std::vector<double> cumulative_area(n_tri);
  std::vector<Eigen::Vector3f> face_normal(n_tri);
  // The signed volume tells whether the winding is outward; a mesh wound the other way round
  // gets all its normals flipped rather than pointing into the model.
  double total_area = 0.0, signed_volume = 0.0;
  for (std::size_t t = 0; t < n_tri; ++t) {
    const Eigen::Vector3i& f = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>();
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double norm = cross.norm();
    total_area += 0.5 * norm;
    cumulative_area[t] = total_area;
    signed_volume += a.dot(b.cross(c)) / 6.0;
    face_normal[t] =
        norm > 0.0 ? Eigen::Vector3f((cross / norm).cast<float>()) : Eigen::Vector3f::UnitZ();
  }
  if (signed_volume < 0.0) {
    for (auto& n : face_normal) n = -n;
  }
  ModelCloud out;
  if (total_area <= 0.0) return out;
  const std::size_t count = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::llround(total_area / (spacing_m * spacing_m))));
  out.points.reserve(count);
  out.normals.reserve(count);
  std::mt19937_64 rng(seed);
  for (std::size_t i = 0; i < count; ++i) {
    const double pick = unit(rng) * total_area;
    const std::size_t t = std::min<std::size_t>(
        static_cast<std::size_t>(
            std::upper_bound(cumulative_area.begin(), cumulative_area.end(), pick) -
            cumulative_area.begin()),
        n_tri - 1);
    const Eigen::Vector3i& f = mesh.triangles[t];
    // Uniform over the triangle: the square-root warp of two uniforms.
    const double r1 = std::sqrt(unit(rng)), r2 = unit(rng);
    const Eigen::Vector3f p = static_cast<float>(1.0 - r1) * mesh.vertices[f[0]] +
                              static_cast<float>(r1 * (1.0 - r2)) * mesh.vertices[f[1]] +
                              static_cast<float>(r1 * r2) * mesh.vertices[f[2]];
    out.points.push_back(p);
    out.normals.push_back(face_normal[t]);
  }
  out.bounding_radius_m = bounding_radius(out.points);
  return out;
}

ModelCloud load_model_cloud(const std::filesystem::path& file, double spacing_m) {
  const std::string ext = lower_extension(file);
  ModelCloud out;
  if (ext == ".off") return sample_mesh(load_mesh(file), spacing_m);
  if (ext == ".ply") {
    pcl::PolygonMesh pm;
    read_ply(file, pm);
    if (!pm.polygons.empty()) {
      TriangleMesh mesh = mesh_from_pcl(pm, file);
      if (mesh.triangles.empty()) fail(file, "holds no triangles");
      return sample_mesh(mesh, spacing_m);
    }
    out.points = xyz_of(pm.cloud);
  } else if (ext == ".pcd") {
    if (!std::filesystem::exists(file)) fail(file, "no such file");
    pcl::PCLPointCloud2 cloud;
    if (pcl::io::loadPCDFile(file.string(), cloud) < 0) fail(file, "cannot read as PCD");
    out.points = xyz_of(cloud);
  } else {
    fail(file, "unsupported model format '" + ext + "' (expected .ply, .pcd or .off)");
  }
  if (out.points.size() < 3) fail(file, "holds fewer than 3 valid points");
  out.normals = estimate_normals(out.points);
  out.bounding_radius_m = bounding_radius(out.points);
  return out;
}

}  // namespace projtour::perception
