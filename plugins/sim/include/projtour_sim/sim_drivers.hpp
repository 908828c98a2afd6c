#pragma once
// The simulated drivers: thin views of the run's one SimWorld behind the hardware interfaces.
// Each advances the world in update() (the world ignores a time it has already reached).
#include <memory>

#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/params.hpp"
#include "projtour_sim/sim_world.hpp"

namespace projtour::sim {

class SimBase : public BaseDriver {
 public:
  // params: velocity_time_constant_s (number), collision handled by the world.
  SimBase(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override;
  GroundTruth* ground_truth() override { return world_.get(); }
  void command_velocity(double v_mps, double w_radps) override;
  Odometry odometry() const override { return world_->odometry(); }
  SimWorld& world() { return *world_; }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimLaser : public LaserDriver {
 public:
  SimLaser(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override {}
  GroundTruth* ground_truth() override { return world_.get(); }
  std::optional<LaserScan> take_scan() override { return world_->take_scan(); }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimPanTilt : public PanTiltDriver {
 public:
  // params: settle_s (number): time at rest before reached() holds.
  SimPanTilt(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override;
  GroundTruth* ground_truth() override { return world_.get(); }
  void command(const JointAngles& angles) override { world_->command_head(angles); }
  JointAngles measured() const override { return world_->measured_head(); }
  bool reached() const override { return world_->head_reached(); }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimDepthCamera : public DepthCameraDriver {
 public:
  SimDepthCamera(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override {}
  GroundTruth* ground_truth() override { return world_.get(); }
  std::optional<DepthFrame> grab() override { return world_->grab(); }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimColourCamera : public ColourCameraDriver {
 public:
  // params: room_lux, lamp_lumens, noise, blur_px (numbers >= 0; see ColourLight).
  SimColourCamera(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override {}
  GroundTruth* ground_truth() override { return world_.get(); }
  std::optional<ColourFrame> grab() override { return world_->grab_colour(); }
  void set_exposure_ms(double exposure_ms) override { world_->set_colour_exposure_ms(exposure_ms); }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimProjector : public ProjectorDriver {
 public:
  SimProjector(const Params& params, const RunContext& run);
  void update(double t_s) override { world_->advance(t_s); }
  void safe_stop() override;
  GroundTruth* ground_truth() override { return world_.get(); }
  void show(const cv::Mat& frame_bgr) override { world_->show(frame_bgr); }
  void blank() override { world_->blank(); }
  bool is_blank() const override { return world_->is_blank(); }

 private:
  std::shared_ptr<SimWorld> world_;
};

}  // namespace projtour::sim
