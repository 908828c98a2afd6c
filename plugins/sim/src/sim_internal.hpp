#pragma once
// Inside the sim plugin: the referee's geometry shared by evaluate_projection and the pictures.
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <string>

#include "projtour/mission.hpp"
#include "projtour/pinhole.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

// Where four projector pixels really land on a target.
struct TrueProjection {
  std::array<Eigen::Vector2d, 4> chosen_px;
  std::array<Eigen::Vector3d, 4> landed_map;        // on the true surface, or see on_mesh
  std::array<bool, 4> on_mesh{};                    // false: met with the Model Points' plane
  std::array<Eigen::Vector3d, 4> model_points_map;  // true Model Points
  std::array<double, 4> error_px{};                 // chosen pixel vs true Model Point's pixel
};

// `alone` holds the target's true mesh only, in the map frame.
TrueProjection true_projection(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                               const Scene& alone, const Eigen::Isometry3d& T_map_projector,
                               const PinholeModel& projector,
                               const std::array<Eigen::Vector2d, 4>& projector_px);

// A shaded view of the target from 0.6 m in front of it, the landed quadrilateral and the true
// Model Points, written as a PNG.
void write_projection_view(const Scene& alone, const Eigen::Isometry3d& T_map_model,
                           const TrueProjection& projection, const std::string& title,
                           const std::filesystem::path& file);

}  // namespace projtour::sim
