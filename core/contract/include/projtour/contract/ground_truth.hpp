#pragma once
// What only the simulator knows. The executor reads it to fill the report's *_error fields; no
// behaviour may use it.
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/drivers.hpp"

namespace projtour {

struct ProjectionTruth {
  // Per Model Point: where the content corner really lands on the target against where the
  // Model Point truly is on the target's surface (where the perfect ray through it lands; a
  // Model Point of an imperfect model floats off the surface) (mm), and the same in projector
  // pixels.
  std::array<double, 4> error_mm{};
  std::array<double, 4> error_px{};
  // Over the whole content area, so nothing passes by landing four corners well: a grid of
  // content points, where the robot's warp (the homography its four pixels define) puts each
  // on the true surface against where the perfect warp (true projector, true Model Points)
  // would (mm).
  double area_error_mean_mm = 0.0;
  double area_error_max_mm = 0.0;
  // Share of the content's light that lands on anything but the target (an occluder, a
  // person, the wall behind), by the true projector's rays through the content area.
  double light_off_target_fraction = 0.0;
  double mean_mm() const;
  double mean_px() const;
};

// The referee's figures of a building that is not the map (a dry run whose world has unmapped
// objects or people), over the run so far.
struct BuildingTruth {
  int people = 0;            // ever present
  int unmapped_objects = 0;  // listed, clutter and supports
  // Smallest distance from the robot's centre to the edge of any unmapped object or person,
  // what it was, and how often it fell below required_clearance_m (the robot's radius + 0.1 m).
  double min_clearance_m = 0.0;
  std::string min_clearance_to;
  double required_clearance_m = 0.0;
  int clearance_violations = 0;
  // Ticks (and mission seconds) the lit projector's light fell on a person's head, and on any
  // part of a person.
  int lit_on_head_ticks = 0;
  double lit_on_head_s = 0.0;
  int lit_on_person_ticks = 0;
  double lit_on_person_s = 0.0;
};

class GroundTruth {
 public:
  virtual ~GroundTruth();
  virtual Eigen::Isometry3d true_T_map_base() const = 0;
  // The true base pose as the robot's map draws that place: a map shifted or turned against the
  // building (a world's map error) moves it. The best localization on that map can do; the same
  // as true_T_map_base() when the map is right.
  virtual Eigen::Isometry3d true_T_map_base_as_drawn() const;
  virtual Eigen::Isometry3d true_T_map_camera() const = 0;
  virtual Eigen::Isometry3d true_T_map_model(const std::string& target_id) const = 0;
  // The true projector ray through each pixel the robot chose for a content corner, met with
  // the true target surface. nullopt if the target is unknown.
  virtual std::optional<ProjectionTruth> evaluate_projection(
      const std::string& target_id, const std::array<Eigen::Vector2d, 4>& projector_px) const = 0;
  // The target the tour is visiting now, from the executor. The world's faults are per target,
  // and targets on one object visited again (same model, same pose) are told apart by nothing
  // else; behaviours never call this.
  virtual void set_visited_target(const std::string& target_id) = 0;
  // Writes before.png and after.png into `dir`: a virtual camera in front of the target showing
  // it shaded, the projected quadrilateral where it really lands and the true Model Points;
  // beside it the colour camera's view of the content as last shown, with the true Model
  // Points and (when given) the corners the robot observed in that camera's pixels.
  // nullopt in a world without unmapped objects or people.
  virtual std::optional<BuildingTruth> building_truth() const;
  // A dry run whose base is simulated in another process (projtour-sim-ros2, behind ROS 2
  // topics): the world's base stands where that simulator says it truly is (its true pose, the
  // building's frame). Only the ros2 drivers' link to that simulator calls this, never a
  // behaviour. Throws std::logic_error where the truth cannot follow (the default).
  virtual void follow_true_base(const Pose2D& true_pose);
  // Where the people present now stand (map frame), for the tour picture.
  virtual std::vector<Eigen::Vector2d> people_positions() const;
  virtual void write_projection_views(
      const std::string& target_id, const std::array<Eigen::Vector2d, 4>& pixels_before_align,
      const std::array<Eigen::Vector2d, 4>& pixels_after_align,
      const std::optional<std::array<Eigen::Vector2d, 4>>& observed_colour_px,
      const std::filesystem::path& dir) const = 0;
};

}  // namespace projtour
