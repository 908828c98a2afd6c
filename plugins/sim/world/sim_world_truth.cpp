// The simulated world's truth (GroundTruth): where everything truly is, the projection's and the
// building's referee figures, and the referee's pictures.
#include <algorithm>
#include <opencv2/core.hpp>
#include <sstream>
#include <stdexcept>

#include "bodies/building.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/run_files.hpp"
#include "referee/projection_truth.hpp"
#include "world/world_impl.hpp"

namespace projtour::sim {

// The colour camera's view of the target with what was last shown on it, from where the robot
// stood then, noise-free (the pictures are the same in every run of a seed).
cv::Mat SimWorld::Impl::colour_panel(
    const TrueTarget& t, const std::optional<std::array<Eigen::Vector2d, 4>>& observed_px) const {
  const cv::Mat frame = targets.last_frame(t);
  const bool shown = !frame.empty() && t.last_shown_s;
  const Eigen::Isometry3d T_map_camera_then = shown ? t.T_map_camera_shown : T_map_camera();
  const Eigen::Isometry3d T_map_projector_then =
      shown ? t.T_map_projector_shown : T_map_projector();
  ColourRenderer& renderer = colour();
  cv::Mat radiance;
  renderer.render(bodies.scene,
                  view_version(const_cast<Impl*>(this)->colour_camera.view, T_map_camera_then),
                  T_map_camera_then, T_map_projector_then, shown ? &frame : nullptr, radiance);
  const double max_ms = max_colour_exposure_ms();
  const double fixed_ms = mission->robot.structured_light.exposure_ms;
  const double exposure_ms = fixed_ms > 0.0 ? std::min(fixed_ms, max_ms)
                                            : renderer.auto_exposure_ms(radiance, 0.1, max_ms);
  const ColourFrame image = renderer.expose(radiance, exposure_ms, nullptr);
  std::array<Eigen::Vector3d, 4> model_points_map;
  for (int i = 0; i < 4; ++i) {
    model_points_map[i] = targets.object(t).T_map_model * t.spec->model_points[i];
  }
  std::ostringstream caption;
  caption.precision(1);
  caption << std::fixed;
  if (shown) {
    caption << "colour camera: as last shown, t = " << *t.last_shown_s << " s, " << exposure_ms
            << " ms";
  } else {
    caption << "colour camera: nothing shown on this target";
  }
  return colour_view_panel(image, T_map_camera_then, model_points_map, observed_px, caption.str());
}

const perception::TriangleMesh& SimWorld::true_mesh(const std::string& target_id) const {
  const TrueTarget* t = impl_->targets.find(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  return *impl_->targets.object(*t).mesh;
}

Eigen::Isometry3d SimWorld::true_T_map_base() const {
  return impl_->T_map_base();
}

Eigen::Isometry3d SimWorld::true_T_map_base_as_drawn() const {
  const Pose2D p = impl_->true_pose();
  const host::MapErrorSpec& error = impl_->world.map_error;
  const Eigen::Vector2d on_map =
      map_point_of(Eigen::Vector2d(p.x_m, p.y_m), error,
                   Eigen::Vector2d(impl_->mission->start.x_m, impl_->mission->start.y_m));
  return isometry_from_pose2d(
      Pose2D{on_map.x(), on_map.y(), wrap_angle_rad(p.yaw_rad - deg_to_rad(error.rotation_deg))});
}

Eigen::Isometry3d SimWorld::true_T_map_camera() const {
  return impl_->T_map_camera();
}

Eigen::Isometry3d SimWorld::true_T_map_projector() const {
  return impl_->T_map_projector();
}

Eigen::Isometry3d SimWorld::true_T_map_model(const std::string& target_id) const {
  const TrueTarget* t = impl_->targets.find(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  return impl_->targets.object(*t).T_map_model;
}

std::optional<ProjectionTruth> SimWorld::evaluate_projection(
    const std::string& target_id, const std::array<Eigen::Vector2d, 4>& projector_px) const {
  const TrueTargets& targets = impl_->targets;
  const TrueTarget* t = targets.find(target_id);
  if (t == nullptr) return std::nullopt;
  const PinholeModel& k = impl_->mission->robot.projector.intrinsics;
  const TrueObject& object = targets.object(*t);
  const TrueProjection truth = true_projection(*t->spec, object.T_map_model, targets.alone(*t),
                                               true_T_map_projector(), k, projector_px);
  ProjectionTruth out;
  for (int i = 0; i < 4; ++i) {
    out.error_mm[i] = truth.error_mm(i);
    out.error_px[i] = truth.error_px[i];
  }
  const AreaFigures area =
      area_figures(*t->spec, object.T_map_model, targets.alone(*t), impl_->bodies.scene,
                   object.object_id, true_T_map_projector(), k, projector_px);
  out.area_error_mean_mm = area.error_mean_mm;
  out.area_error_max_mm = area.error_max_mm;
  out.light_off_target_fraction = area.light_off_target_fraction;
  return out;
}

void SimWorld::set_visited_target(const std::string& target_id) {
  TrueTargets& targets = impl_->targets;
  const TrueTarget* t = targets.find(target_id);
  targets.visited.reset();
  if (t != nullptr) targets.visited = static_cast<std::size_t>(t - targets.targets.data());
}

void SimWorld::write_projection_views(
    const std::string& target_id, const std::array<Eigen::Vector2d, 4>& pixels_before_align,
    const std::array<Eigen::Vector2d, 4>& pixels_after_align,
    const std::optional<std::array<Eigen::Vector2d, 4>>& observed_colour_px,
    const std::filesystem::path& dir) const {
  const TrueTarget* t = impl_->targets.find(target_id);
  if (t == nullptr) throw std::out_of_range("simulated world: no target '" + target_id + "'");
  const Eigen::Isometry3d T_map_projector = true_T_map_projector();
  const PinholeModel& k = impl_->mission->robot.projector.intrinsics;
  const Eigen::Isometry3d& T_map_model = impl_->targets.object(*t).T_map_model;
  const Scene& alone = impl_->targets.alone(*t);
  const cv::Mat colour_view = impl_->colour_panel(*t, observed_colour_px);
  make_run_directory(dir);
  write_projection_view(
      alone, T_map_model,
      true_projection(*t->spec, T_map_model, alone, T_map_projector, k, pixels_before_align),
      "before alignment", colour_view, dir / "before.png");
  write_projection_view(
      alone, T_map_model,
      true_projection(*t->spec, T_map_model, alone, T_map_projector, k, pixels_after_align),
      "after alignment", colour_view, dir / "after.png");
}

std::vector<Eigen::Vector2d> SimWorld::people_positions() const {
  std::vector<Eigen::Vector2d> out;
  if (impl_->crowd) {
    for (const auto& [index, at] : impl_->crowd->positions()) out.push_back(at);
  }
  return out;
}

std::optional<BuildingTruth> SimWorld::building_truth() const {
  const Impl& w = *impl_;
  if (!w.crowd && w.bodies.footprints.empty()) return std::nullopt;
  BuildingTruth out = w.referee.figures();
  out.people = w.crowd ? static_cast<int>(w.crowd->size()) : 0;
  out.unmapped_objects = static_cast<int>(w.bodies.footprints.size());
  out.required_clearance_m = w.bodies.robot_radius_m + kClearanceMarginM;
  return out;
}

}  // namespace projtour::sim
