// model_io: mesh loading (PLY, OFF), area-weighted sampling and point-cloud normals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "projtour/perception/model.hpp"
#include "sim_test_scenes.hpp"

namespace projtour {
namespace {

const std::filesystem::path kBunny =
    std::filesystem::path(PROJTOUR_SOURCE_DIR) / "examples/models/bunny.ply";

std::filesystem::path temp_file(const std::string& name, const std::string& text) {
  const auto path = sim::testing::test_temp_path(name);
  std::ofstream(path) << text;
  return path;
}

// A unit cube centred on the origin, quads wound outward.
const char* const kCubeOff =
    "OFF\n# a cube\n8 6 12\n"
    "-0.5 -0.5 -0.5\n0.5 -0.5 -0.5\n0.5 0.5 -0.5\n-0.5 0.5 -0.5\n"
    "-0.5 -0.5 0.5\n0.5 -0.5 0.5\n0.5 0.5 0.5\n-0.5 0.5 0.5\n"
    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n";

TEST(ModelIo, LoadsBunnyPly) {
  const perception::TriangleMesh mesh = perception::load_mesh(kBunny);
  EXPECT_EQ(mesh.vertices.size(), 1839u);
  EXPECT_EQ(mesh.triangles.size(), 3674u);
}

TEST(ModelIo, LoadsOffAndTriangulatesQuads) {
  const perception::TriangleMesh mesh = perception::load_mesh(temp_file("cube.off", kCubeOff));
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.triangles.size(), 12u);
}

TEST(ModelIo, MissingFileNamesIt) {
  try {
    perception::load_mesh("/nonexistent/thing.ply");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/thing.ply"), std::string::npos);
  }
  EXPECT_THROW(perception::load_mesh(temp_file("bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n")),
               std::runtime_error);
}

TEST(ModelIo, SampleMeshIsUniformOutwardAndDeterministic) {
  const perception::TriangleMesh cube = perception::load_mesh(temp_file("cube2.off", kCubeOff));
  const ModelCloud a = perception::sample_mesh(cube, 0.01, 7);
  const ModelCloud b = perception::sample_mesh(cube, 0.01, 7);
  const ModelCloud c = perception::sample_mesh(cube, 0.01, 8);
  // Area 6 m^2 at 1 cm spacing: 60000 points.
  ASSERT_EQ(a.points.size(), 60000u);
  EXPECT_EQ(a.points, b.points);
  EXPECT_NE(a.points, c.points);
  int top = 0;
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    const Eigen::Vector3f& p = a.points[i];
    // On the surface: one coordinate at +-0.5, and the face normal points outward along it.
    int axis;
    p.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(p[axis]), 0.5f, 1e-5f);
    EXPECT_NEAR(a.normals[i].dot(p.normalized()), std::abs(p.normalized()[axis]), 1e-4f);
    if (p.z() > 0.4999f) ++top;
  }
  // One face in six, within a few sigma of the binomial.
  EXPECT_NEAR(top, 10000, 400);
  EXPECT_NEAR(a.bounding_radius_m, std::sqrt(0.75f), 0.01f);
}

TEST(ModelIo, ModelCloudFromBunnyMesh) {
  const ModelCloud cloud = perception::load_model_cloud(kBunny, 0.003);
  EXPECT_GT(cloud.points.size(), 2000u);
  EXPECT_EQ(cloud.points.size(), cloud.normals.size());
  EXPECT_GT(cloud.bounding_radius_m, 0.1f);
  EXPECT_LT(cloud.bounding_radius_m, 0.25f);
  // Mostly outward normals.
  int outward = 0;
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    if (cloud.normals[i].dot(cloud.points[i]) > 0) ++outward;
  }
  EXPECT_GT(outward, static_cast<int>(0.8 * cloud.points.size()));
}

TEST(ModelIo, PointCloudPlyGetsOutwardPcaNormals) {
  // Points on a sphere of radius 0.1 m, no faces: normals must be radial.
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 2000\nproperty float x\nproperty float y\nproperty "
      "float z\nend_header\n";
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 2000; ++i) {
    // Fibonacci sphere.
    const double z = 1.0 - 2.0 * (i + 0.5) / 2000.0, r = std::sqrt(1 - z * z), phi = i * 2.399963;
    const Eigen::Vector3f p =
        0.1f * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z).cast<float>();
    ply += std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
  }
  const ModelCloud cloud = perception::load_model_cloud(temp_file("sphere.ply", ply), 0.005);
  ASSERT_EQ(cloud.points.size(), 2000u);
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    EXPECT_GT(cloud.normals[i].dot(cloud.points[i].normalized()), 0.98f);
  }
  EXPECT_NEAR(cloud.bounding_radius_m, 0.1f, 1e-3f);
  EXPECT_THROW(perception::load_mesh(temp_file("sphere2.ply", ply)), std::runtime_error);
}

// A point-only copy of the bunny's surface samples: the estimated normals must follow the mesh's
// face normals (the ones sample_mesh gives) and come out the same bit for bit on every load.
TEST(ModelIo, PointCloudBunnyNormalsFollowTheSurfaceAndRepeat) {
  const ModelCloud truth = perception::sample_mesh(perception::load_mesh(kBunny), 0.003);
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(truth.points.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  char line[96];
  for (const auto& p : truth.points) {
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", p.x(), p.y(), p.z());
    ply += line;
  }
  const auto file = temp_file("bunny_points.ply", ply);
  const ModelCloud a = perception::load_model_cloud(file, 0.003);
  const ModelCloud b = perception::load_model_cloud(file, 0.003);
  ASSERT_EQ(a.points.size(), truth.points.size());
  EXPECT_EQ(a.normals, b.normals);
  std::vector<double> angle_deg;
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    const double c = std::clamp(static_cast<double>(a.normals[i].dot(truth.normals[i])), -1.0, 1.0);
    angle_deg.push_back(std::acos(c) * 180.0 / M_PI);
  }
  std::sort(angle_deg.begin(), angle_deg.end());
  const double median = angle_deg[angle_deg.size() / 2];
  const double within_30 =
      static_cast<double>(std::lower_bound(angle_deg.begin(), angle_deg.end(), 30.0) -
                          angle_deg.begin()) /
      static_cast<double>(angle_deg.size());
  RecordProperty("median_deg", std::to_string(median));
  RecordProperty("within_30_deg", std::to_string(within_30));
  std::printf("bunny point normals: median %.2f deg off the face normal, %.1f%% within 30 deg\n",
              median, 100.0 * within_30);
  EXPECT_LT(median, 10.0);
  EXPECT_GT(within_30, 0.9);
}

}  // namespace
}  // namespace projtour
