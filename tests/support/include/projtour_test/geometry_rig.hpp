#pragma once
// An in-process run for the geometry behaviours: a UD-like robot, fake pan-tilt and projector
// drivers, a stepped clock, and the plugins loaded through the real plugin loader.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/run_rig.hpp"

namespace projtour::geometry_test {

class FakeProjector : public ProjectorDriver {
 public:
  void show(const cv::Mat& frame_bgr) override;
  void blank() override {
    blank_ = true;
    ++blanks;
  }
  bool is_blank() const override { return blank_; }
  void safe_stop() override { blank(); }
  std::vector<cv::Mat> frames;
  int blanks = 0;

 private:
  bool blank_ = true;
};

// Moves to each command after `ticks_to_reach` updates; records whether the projector was blank
// when each command came.
class FakePanTilt : public PanTiltDriver {
 public:
  explicit FakePanTilt(const ProjectorDriver* projector) : projector_(projector) {}
  void update(double t_s) override;
  void safe_stop() override {}
  void command(const JointAngles& angles) override;
  JointAngles measured() const override { return measured_; }
  bool reached() const override { return remaining_ticks_ == 0; }
  std::vector<JointAngles> commands;
  std::vector<bool> projector_blank_at_command;
  int ticks_to_reach = 3;
  JointAngles measured_;

 private:
  const ProjectorDriver* projector_;
  int remaining_ticks_ = 0;
};

PinholeModel ud_projector_intrinsics();
RobotSpec ud_like_robot();
// A target whose front (+x) faces the map's -x, 3 m ahead of a robot at the origin, with a
// 0.4 x 0.25 m rectangle of Model Points on its front face.
TargetSpec wall_target(const std::string& id, double x_m, double y_m);
// Writes a 800x500 content image with four coloured quadrants (TL red, TR green, BR blue,
// BL white) and returns its path.
std::filesystem::path write_quadrant_content(const std::filesystem::path& dir);

struct Rig {
  Rig();
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;
  std::shared_ptr<Behaviour> make(const std::string& kind,
                                  const std::map<std::string, ParamValue>& overrides = {});
  // Starts and ticks (advancing the clock by dt_s and updating drivers) until an outcome.
  Outcome run(Behaviour& b, double dt_s = 0.1, int max_ticks = 10000);
  void set_target(std::size_t index);
  // The exact camera-model transform for the robot at `base` with the head at its measured
  // angles.
  Eigen::Isometry3d exact_T_camera_model(const Pose2D& base, const TargetSpec& target) const;

  // First, so it is destroyed last: blackboard values set by a plugin (std::any) keep code of
  // that plugin, which must stay loaded until they are gone.
  host::PluginRegistry registry;
  test::RunRig rig;
  const std::filesystem::path& dir = rig.run.run_dir;
  MissionSpec& mission = rig.mission;
  SteppedClock& clock = rig.clock;
  Blackboard& blackboard = rig.blackboard;
  test::RecordingLogger& log = rig.log;
  std::shared_ptr<FakeProjector> projector;
  std::shared_ptr<FakePanTilt> pan_tilt;
  DriverSet& drivers = rig.drivers;
  RunContext& run_ctx = rig.run;
  CancelToken& cancel = rig.cancel;
  Params params;
  Context ctx;
  std::vector<std::unique_ptr<Params>> params_keep;
  int ticks_before_cancel = -1;
};

}  // namespace projtour::geometry_test
