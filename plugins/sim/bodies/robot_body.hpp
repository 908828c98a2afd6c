#pragma once
// Inside the sim plugin: the robot's bodies in the world. The base (MRPT's differential drive
// for the true motion, odometry with a per-run bias and noise), the pan-tilt head (true,
// commanded and measured joints), the laser, both cameras and the projector: each one's state
// and what it does from its own state alone. What crosses bodies (the bumper, what a ray meets)
// is the world's.
#include <mrpt/kinematics/CVehicleSimul_DiffDriven.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "projtour/contract/drivers.hpp"
#include "projtour/contract/robot.hpp"
#include "projtour/contract/run_files.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/host/world.hpp"
#include "projtour_sim/colour_renderer.hpp"
#include "projtour_sim/depth_renderer.hpp"
#include "projtour_sim/kinect_noise.hpp"
#include "projtour_sim/sim_world.hpp"

namespace projtour::sim {

struct SimBaseBody {
  mrpt::kinematics::CVehicleSimul_DiffDriven vehicle;
  double collision_radius_m = 0.15;
  Pose2D odometry_pose;
  double odometry_v = 0.0, odometry_w = 0.0;
  double odometry_trans_bias = 0.0, odometry_rot_bias = 0.0;
  bool blocked = false;
  bool moving = false;

  Pose2D true_pose() const;
  // One motion step of dt_s: the true motion, the bumper (a pose `collides` refuses stops the
  // base where it was), then odometry from the true increment, drawing from `rng`.
  void step(double dt_s, const std::function<bool(const Pose2D&)>& collides,
            const host::WorldSpec& world, std::mt19937_64& rng);
};

struct SimHeadBody {
  JointAngles q_true, q_command, q_measured;
  double settle_s = 0.1;
  double at_rest_since_s = -1e9;  // at rest since before the mission
  bool moving_now = false;
  std::unique_ptr<head::HeadKinematics> kinematics;  // the true one: the projector's true mount

  // Moves the true joints toward the command at the head's rate, then reads the encoders (bias
  // and noise from `rng`) at mission time t_s.
  void step(double dt_s, double t_s, const PanTiltSpec& spec, const host::WorldSpec& world,
            std::mt19937_64& rng);
};

struct SimLaserBody {
  float threshold = 0.6f;
  double next_scan_s = 0.0;
  std::optional<LaserScan> scan;
};

// What the cameras' caches are keyed by: the scene's rebuilds and the people they could see
// (people walking elsewhere leave a camera's image as it was).
struct ViewKey {
  std::uint64_t counter = 0;
  std::uint64_t scene_version = ~0ull;
  std::vector<PersonShape> seen;
};

struct SimDepthBody {
  double next_frame_s = 0.0;
  std::optional<double> frame_due_s;
  std::uint64_t frame_sequence = 0;
  IdealDepth ideal;
  std::optional<std::pair<std::uint64_t, Eigen::Isometry3d>> ideal_key;  // what `ideal` shows
  ViewKey view;
  std::unique_ptr<DepthRenderer> renderer;
  KinectNoiseParams kinect;
};

// Its renderer is made on first use: most runs never grab a colour frame.
struct SimColourBody {
  double next_frame_s = 0.0;
  std::optional<double> frame_due_s;
  std::uint64_t sequence = 0;
  double exposure_ms = 0.0;  // 0 = automatic
  ColourLight light;
  ViewKey view;
  mutable std::unique_ptr<ColourRenderer> renderer;
  cv::Mat radiance;
};

struct SimProjectorBody {
  bool lit = false;
  cv::Mat shown;                        // 8-bit BGR: what the projector shows while lit
  std::optional<std::size_t> last_lit;  // the target whose last_frame is raw
  std::vector<ProjectorEvent> log;
  double lit_moving_s = 0.0;
  AppendOnlyFile jsonl;  // appended on resume, like events.jsonl

  // Keeps the event, and writes it to the log file once one is set.
  void record(const ProjectorEvent& e);
};

}  // namespace projtour::sim
