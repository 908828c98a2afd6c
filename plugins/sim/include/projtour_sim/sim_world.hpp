#pragma once
// The simulated world of a dry run: one per run, shared by the six simulated drivers (the first
// one created makes it, the others attach). It advances once per distinct mission time, knows
// the truth (true base pose, true head, true target meshes and poses, the true camera-projector
// calibration) and referees the projection.
//
// World-file keys it reads (WorldSpec, see examples/worlds/atrium_faults.yaml): targets (true
// poses), target_offset, noise (odometry, laser, encoders, depth), model_error, calibration_error
// and faults. What each fault does, its numbers and their defaults are one table, core/host's
// projtour/host/world_faults.hpp (documented for users in examples/worlds/atrium_faults.yaml); the
// simulator's side of them is faults/sim_faults.hpp.
// Faults other than the static obstacles (target_missing, occluder, blocked_path, pole) act while
// their target is the one the robot is at: the nearest target within its stand-off + 1.5 m.
//
// The building (world keys objects, clutter, supports, map_error, glass, people; documented in
// examples/worlds/busy_building.yaml; see bodies/ and people/): its walls are the map's edited by
// the map error, glass is in them for the bumper and not for the laser or the cameras, and the
// unmapped objects and the people are met by the laser, the cameras, the light and the bumper
// (the bumper at the robot's radius). The referee records the robot's clearance to each object
// and person and whether lit light falls on anyone (BuildingTruth).
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/host/world.hpp"
#include "projtour/perception/model.hpp"
#include "projtour_sim/colour_renderer.hpp"

namespace cv {
class Mat;
}

namespace projtour::sim {

struct ProjectorEvent {
  double t_s = 0.0;
  bool shown = false;  // false: blanked
  bool base_moving = false;
  bool head_moving = false;
  std::string target;  // the active target, "" when none
};

class SimWorld : public GroundTruth {
 public:
  // The world of this run, created on first use (keyed by the RunContext's address).
  static std::shared_ptr<SimWorld> attach(const RunContext& run);
  explicit SimWorld(const RunContext& run);
  ~SimWorld() override;
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  // Advances to mission time t_s; repeated or older times are ignored.
  void advance(double t_s);
  double time_s() const;

  // Base.
  void set_velocity_time_constant(double tau_s);
  void command_velocity(double v_mps, double w_radps);
  Odometry odometry() const;
  bool base_blocked() const;  // the last motion step ran into an obstacle
  bool base_moving() const;

  // Laser.
  void set_laser_occupancy_threshold(double threshold);
  std::optional<LaserScan> take_scan();

  // Pan-tilt.
  void set_head_settle_time(double settle_s);
  void command_head(const JointAngles& angles);
  JointAngles measured_head() const;
  bool head_reached() const;
  bool head_moving() const;
  JointAngles true_head() const;

  // Depth camera.
  void set_max_incidence_deg(double deg);
  std::optional<DepthFrame> grab();

  // Colour camera: renders the scene from the true colour pose with the robot's colour
  // intrinsics, under room light and the true projector's light (see colour_renderer.hpp),
  // at camera.colour.rate_hz. Noise from a stream of its own. Starts in automatic exposure.
  void set_colour_light(const ColourLight& light);
  // 0 = automatic; longer than a frame period is cut to it. Throws std::invalid_argument < 0.
  void set_colour_exposure_ms(double exposure_ms);
  std::optional<ColourFrame> grab_colour();

  // Projector. Events also go, one JSON object a line, to the log file once one is set.
  void set_projector_log_file(const std::filesystem::path& file);
  void show(const cv::Mat& frame_bgr);
  void blank();
  bool is_blank() const;
  const std::vector<ProjectorEvent>& projector_log() const;
  // Mission seconds the projector was lit while the base or the head moved (should stay 0).
  double lit_while_moving_s() const;

  // The target whose faults act now ("" when none).
  std::string active_target() const;
  // The surface the camera sees (model frame): the mission's mesh plus the model error.
  const perception::TriangleMesh& true_mesh(const std::string& target_id) const;
  // Teleports the true base (tests and the kidnap fault); odometry does not notice.
  void set_true_base_pose(const Pose2D& pose);

  // GroundTruth.
  Eigen::Isometry3d true_T_map_base() const override;
  Eigen::Isometry3d true_T_map_base_as_drawn() const override;
  Eigen::Isometry3d true_T_map_camera() const override;
  Eigen::Isometry3d true_T_map_model(const std::string& target_id) const override;
  // The true projector pose: the robot file's mount perturbed by the calibration error.
  Eigen::Isometry3d true_T_map_projector() const;
  // A ray that misses the true mesh is met with the plane of the true Model Points instead.
  // The area errors come from a 9x9 grid of content points, the light off the target from
  // 32x32 (content beyond the projector's image counts as off it); all three are NaN when the
  // four pixels, or the true Model Points in the true projector, carry no homography.
  std::optional<ProjectionTruth> evaluate_projection(
      const std::string& target_id,
      const std::array<Eigen::Vector2d, 4>& projector_px) const override;
  void set_visited_target(const std::string& target_id) override;
  // The base of this world is another process's (projtour-sim-ros2): it stands where that one's
  // does, and its own motion model stays idle (nobody here commands it).
  void follow_true_base(const Pose2D& true_pose) override { set_true_base_pose(true_pose); }
  std::optional<BuildingTruth> building_truth() const override;
  std::vector<Eigen::Vector2d> people_positions() const override;
  // Beside each view, the colour camera's: noise-free at the structured light's exposure, with
  // the frame last shown while this target was active, from where the robot stood then.
  void write_projection_views(
      const std::string& target_id, const std::array<Eigen::Vector2d, 4>& pixels_before_align,
      const std::array<Eigen::Vector2d, 4>& pixels_after_align,
      const std::optional<std::array<Eigen::Vector2d, 4>>& observed_colour_px,
      const std::filesystem::path& dir) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace projtour::sim
