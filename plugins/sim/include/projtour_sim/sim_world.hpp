#pragma once
// The simulated world of a dry run: one per run, shared by the six simulated drivers (the first
// one created makes it, the others attach). It advances once per distinct mission time, knows
// the truth (true base pose, true head, true target meshes and poses, the true camera-projector
// calibration) and referees the projection.
//
// World-file keys it reads (WorldSpec, see examples/worlds/atrium_faults.yaml): targets (true
// poses), target_offset, noise (odometry, laser, encoders, depth), model_error, calibration_error
// and faults. Fault numbers, all optional:
//   frame_dropout      fraction (0.5)        share of depth frames delivered empty (the colour
//                                            camera's frames all arrive)
//   target_missing     -                     the target is not there at all
//   occluder           distance_m (0.5), width_m (0.4), height_m (0.4)
//                      a hanging board (above the laser plane) that far in front of the target
//   blocked_path       size_m (0.6)          a box on the target's stand-off pose (laser sees it)
//   kidnap             distance_m (1.0)      the true pose jumps when the robot arrives
//   camera_disconnect  after_frames (0)      grab() throws after that many frames, and
//                                            grab_colour() after that many colour frames
//   projector_failure  after_shows (0)       show() throws after that many shows
//   target_nudge       after_s (1.0), distance_m (0.02), direction_deg (90), yaw_deg (0)
//                      the true target moves once, after_s seconds after the projector first
//                      lit it (so during the dwell): shifted that far in the map along
//                      direction_deg (counter-clockwise from the map's +x; dx_m/dy_m instead
//                      give the shift directly) and turned yaw_deg about its own z axis. The
//                      camera and the referee see the moved target from then on.
//   pole               distance_m (0.6), diameter_m (0.05), offset_m (0)
//                      a vertical pole (16-sided prism) from the floor to 2 m, that far in
//                      front of the target toward its stand-off pose and offset_m sideways
//                      (positive = left seen from the target): the cameras see it, it takes
//                      the projector's light and shadows what is behind, and the laser and the
//                      bumper meet it (unless it stands on the stand-off pose itself, where it
//                      would be blocked_path: then only the cameras and the light meet it).
//   daylight           lux (20000)
//                      sunlight through a window floods the target's surroundings: the colour
//                      camera's room light is that bright while the target is the active one
//                      (the structured light and the verification dots drown in it).
//   person_crossing    after_s (1.0), speed_mps (1.0), distance_m (0.45), times (1), every_s (8)
//                      after_s after the projector first lit the target, a person walks across
//                      the line from the target to its stand-off pose, distance_m in front of
//                      the target, from 2 m to one side to 2 m to the other (then gone); again
//                      `times` times every_s apart, each the other way.
//   person_standing    after_s (1.0), for_s (10), distance_m (0.5), speed_mps (1.0)
//                      a person walks in from 2.5 m to the side, stands for_s distance_m in
//                      front of the target (in the beam), and walks off the way they came.
// Faults other than the static obstacles (target_missing, occluder, blocked_path, pole) act while
// their target is the one the robot is at: the nearest target within its stand-off + 1.5 m.
//
// The building (world keys objects, clutter, supports, map_error, glass, people; documented in
// examples/worlds/busy_building.yaml; see building.hpp): its walls are the map's edited by the
// map error, glass is in them for the bumper and not for the laser or the cameras, and the
// unmapped objects and the people are met by the laser, the cameras, the light and the bumper
// (the bumper at the robot's radius). The referee records the robot's clearance to each object
// and person and whether lit light falls on anyone (BuildingTruth).
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/context.hpp"
#include "projtour/drivers.hpp"
#include "projtour/ground_truth.hpp"
#include "projtour/model.hpp"
#include "projtour/world.hpp"
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
  const TriangleMesh& true_mesh(const std::string& target_id) const;
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
