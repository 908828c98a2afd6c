// The simulated drivers over the shared world.
#include "projtour_sim/sim_drivers.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace projtour::sim {

SimBase::SimBase(const Params& params, const RunContext& run) : world_(SimWorld::attach(run)) {
  if (params.has("velocity_time_constant_s")) {
    world_->set_velocity_time_constant(params.number("velocity_time_constant_s"));
  }
}

void SimBase::safe_stop() {
  try {
    world_->command_velocity(0.0, 0.0);
  } catch (...) {
    // safe_stop must not throw; a stop command cannot fail in the simulator anyway.
  }
}

void SimBase::command_velocity(double v_mps, double w_radps) {
  world_->command_velocity(v_mps, w_radps);
}

SimLaser::SimLaser(const Params& params, const RunContext& run) : world_(SimWorld::attach(run)) {
  if (params.has("occupancy_threshold")) {
    world_->set_laser_occupancy_threshold(params.number("occupancy_threshold"));
  }
}

SimPanTilt::SimPanTilt(const Params& params, const RunContext& run)
    : world_(SimWorld::attach(run)) {
  if (params.has("settle_s")) world_->set_head_settle_time(params.number("settle_s"));
}

void SimPanTilt::safe_stop() {
  // Holding: command where the head is now.
  world_->command_head(world_->true_head());
}

SimDepthCamera::SimDepthCamera(const Params& params, const RunContext& run)
    : world_(SimWorld::attach(run)) {
  if (params.has("max_incidence_deg")) {
    world_->set_max_incidence_deg(params.number("max_incidence_deg"));
  }
}

SimColourCamera::SimColourCamera(const Params& params, const RunContext& run)
    : world_(SimWorld::attach(run)) {
  ColourLight light;
  const auto read = [&](const char* key, double& out) {
    if (!params.has(key)) return;
    const double v = params.number(key);
    if (!(v >= 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("sim_colour_camera: ") + key + " must be >= 0, got " +
                                  std::to_string(v));
    }
    out = v;
  };
  read("room_lux", light.room_lux);
  read("lamp_lumens", light.lamp_lumens);
  read("noise", light.noise);
  read("blur_px", light.blur_px);
  world_->set_colour_light(light);
}

SimProjector::SimProjector(const Params& params, const RunContext& run)
    : world_(SimWorld::attach(run)) {
  const std::string name =
      params.has("log_file") ? params.string("log_file") : std::string("sim_projector_log.jsonl");
  if (!name.empty() && !run.run_dir.empty()) world_->set_projector_log_file(run.run_dir / name);
}

void SimProjector::safe_stop() {
  if (!world_->is_blank()) world_->blank();
}

}  // namespace projtour::sim
