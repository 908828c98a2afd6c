#pragma once
// Target models: the mesh the simulator renders and the cloud the robot aligns.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "projtour/contract/model_cloud.hpp"

namespace projtour::perception {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;   // metres, model frame
  std::vector<Eigen::Vector3i> triangles;  // indices into vertices
};

// PLY or OFF with faces (PCL I/O for PLY). Throws std::runtime_error naming the file when it
// cannot be read or holds no triangles.
TriangleMesh load_mesh(const std::filesystem::path& file);

// The model a robot aligns: a mesh (PLY/OFF with faces) is resampled uniformly over its surface
// at about `spacing_m`; a point cloud (PCD, or PLY without faces) keeps its points and gets
// normals estimated. Normals are computed once, here. Throws std::runtime_error naming the file.
ModelCloud load_model_cloud(const std::filesystem::path& file, double spacing_m);
// align and project's `track` resample a model at the same spacing unless told otherwise, so
// the pose track follows comes from the model align fitted. Text: it is a parameter default.
inline constexpr const char* kDefaultModelSpacingM = "0.003";

// Same, from a mesh in memory (deterministic for a given seed).
ModelCloud sample_mesh(const TriangleMesh& mesh, double spacing_m, unsigned seed = 1);

}  // namespace projtour::perception
