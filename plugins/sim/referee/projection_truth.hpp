#pragma once
// Inside the sim plugin: the referee's geometry shared by evaluate_projection and the pictures.
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/contract/pinhole.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace cv {
class Mat;
}

namespace projtour::sim {

// Where four projector pixels really land on a target.
struct TrueProjection {
  std::array<Eigen::Vector2d, 4> chosen_px;
  std::array<Eigen::Vector3d, 4> landed_map;        // on the true surface, or see on_mesh
  std::array<bool, 4> on_mesh{};                    // false: met with the Model Points' plane
  std::array<Eigen::Vector3d, 4> model_points_map;  // true Model Points
  // Where the perfect ray (through the true Model Point's pixel) lands: the Model Point on the
  // true surface. With model error the Model Point floats up to the error off the surface, where
  // no light can land; the error is measured against this instead, as the area figures are.
  std::array<Eigen::Vector3d, 4> surface_points_map;
  std::array<double, 4> error_px{};  // chosen pixel vs true Model Point's pixel
  double error_mm(int i) const { return 1000.0 * (landed_map[i] - surface_points_map[i]).norm(); }
};

// `alone` holds the target's true mesh only, in the map frame.
TrueProjection true_projection(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                               const Scene& alone, const Eigen::Isometry3d& T_map_projector,
                               const PinholeModel& projector,
                               const std::array<Eigen::Vector2d, 4>& projector_px);

// The referee's figures over the whole content area (ProjectionTruth's area_error_* and
// light_off_target_fraction). The robot's warp is the homography taking the content's unit
// square to the four pixels it chose (undistorted: the ideal projector image), the perfect warp
// the same to the true Model Points in the true projector. `full` is the whole scene, in which
// the target is `object_id`. NaN where a warp does not exist (a Model Point behind the
// projector, four pixels in a line).
struct AreaFigures {
  double error_mean_mm = 0.0;
  double error_max_mm = 0.0;
  double light_off_target_fraction = 0.0;
};
AreaFigures area_figures(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                         const Scene& alone, const Scene& full, int object_id,
                         const Eigen::Isometry3d& T_map_projector, const PinholeModel& projector,
                         const std::array<Eigen::Vector2d, 4>& projector_px);

// A shaded view of the target from 0.6 m in front of it, the landed quadrilateral and the true
// Model Points, written as a PNG; `beside` (when not empty) goes to its right, scaled to its
// height.
void write_projection_view(const Scene& alone, const Eigen::Isometry3d& T_map_model,
                           const TrueProjection& projection, const std::string& title,
                           const cv::Mat& beside, const std::filesystem::path& file);

// The colour camera's frame as a picture for the referee: the true Model Points (map frame)
// through the camera at T_map_camera as green crosses, the corners the robot observed in that
// camera's pixels (when given) as red circles, and the caption.
cv::Mat colour_view_panel(const ColourFrame& frame, const Eigen::Isometry3d& T_map_camera,
                          const std::array<Eigen::Vector3d, 4>& model_points_map,
                          const std::optional<std::array<Eigen::Vector2d, 4>>& observed_px,
                          const std::string& caption);

}  // namespace projtour::sim
