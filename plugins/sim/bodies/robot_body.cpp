// The robot's bodies: the base's motion and odometry, the head's joints, the projector's log.
#include "bodies/robot_body.hpp"

#include <mrpt/poses/CPose2D.h>

#include <cmath>
#include <iostream>
#include <sstream>

#include "projtour/contract/geometry.hpp"
#include "world/random_streams.hpp"

namespace projtour::sim {

Pose2D SimBaseBody::true_pose() const {
  const auto& p = vehicle.getCurrentGTPose();
  return {p.x, p.y, p.phi};
}

void SimBaseBody::step(double dt_s, const std::function<bool(const Pose2D&)>& collides,
                       const host::WorldSpec& world, std::mt19937_64& rng) {
  const Pose2D before = true_pose();
  vehicle.simulateOneTimeStep(dt_s);
  Pose2D after = true_pose();
  if (collides(after) && !collides(before)) {
    // The bumper: the base stops where it was; pushing on keeps it there.
    vehicle.setCurrentGTPose(mrpt::math::TPose2D(before.x_m, before.y_m, before.yaw_rad));
    vehicle.movementCommand(0.0, 0.0);
    vehicle.setV(0.0);
    vehicle.setW(0.0);
    blocked = true;
    after = before;
  } else if (std::hypot(after.x_m - before.x_m, after.y_m - before.y_m) > 1e-9) {
    blocked = false;  // moved freely again
  }
  // Odometry integrates the true local increment with a per-run scale bias and white noise.
  const mrpt::poses::CPose2D delta = mrpt::poses::CPose2D(after.x_m, after.y_m, after.yaw_rad) -
                                     mrpt::poses::CPose2D(before.x_m, before.y_m, before.yaw_rad);
  const double trans_noise = world.odometry_trans_noise_frac * 0.3 * gaussian(rng);
  const double rot_noise = world.odometry_rot_noise_frac * 0.3 * gaussian(rng);
  const double ts = 1.0 + odometry_trans_bias + trans_noise;
  const double rs = 1.0 + odometry_rot_bias + rot_noise;
  const mrpt::poses::CPose2D measured(delta.x() * ts, delta.y() * ts, delta.phi() * rs);
  const mrpt::poses::CPose2D odo =
      mrpt::poses::CPose2D(odometry_pose.x_m, odometry_pose.y_m, odometry_pose.yaw_rad) + measured;
  odometry_pose = {odo.x(), odo.y(), odo.phi()};
  odometry_v = dt_s > 0 ? delta.x() * ts / dt_s : 0.0;
  odometry_w = dt_s > 0 ? delta.phi() * rs / dt_s : 0.0;
  // The first-order lag never quite reaches zero: below 1 mm/s and 0.06 deg/s counts as still.
  moving = dt_s > 0 &&
           (std::hypot(delta.x(), delta.y()) / dt_s > 1e-3 || std::abs(delta.phi()) / dt_s > 1e-3);
}

void SimHeadBody::step(double dt_s, double t_s, const PanTiltSpec& spec,
                       const host::WorldSpec& world, std::mt19937_64& rng) {
  const double max_step = deg_to_rad(spec.max_rate_dps) * dt_s;
  const JointAngles before = q_true;
  // Within one step of the command the joint lands on it exactly (no rounding creep).
  auto move = [max_step](double q, double target) {
    return std::abs(target - q) <= max_step ? target : q + std::copysign(max_step, target - q);
  };
  q_true.pan_rad = move(q_true.pan_rad, q_command.pan_rad);
  q_true.tilt_rad = move(q_true.tilt_rad, q_command.tilt_rad);
  moving_now = q_true.pan_rad != before.pan_rad || q_true.tilt_rad != before.tilt_rad;
  if (moving_now) at_rest_since_s = t_s;
  const double sigma = deg_to_rad(world.encoder_noise_deg);
  q_measured.pan_rad =
      q_true.pan_rad + deg_to_rad(world.encoder_bias_pan_deg) + sigma * gaussian(rng);
  q_measured.tilt_rad =
      q_true.tilt_rad + deg_to_rad(world.encoder_bias_tilt_deg) + sigma * gaussian(rng);
}

void SimProjectorBody::record(const ProjectorEvent& e) {
  log.push_back(e);
  if (!jsonl.is_open()) return;
  std::ostringstream line;
  line << "{\"t\": " << e.t_s << ", \"event\": \"" << (e.shown ? "show" : "blank")
       << "\", \"base_moving\": " << (e.base_moving ? "true" : "false")
       << ", \"head_moving\": " << (e.head_moving ? "true" : "false")
       << ", \"target\": " << (e.target.empty() ? std::string("null") : "\"" + e.target + "\"")
       << "}\n";
  // Called from the safe stop too, which must not throw: the log stops, said once.
  try {
    jsonl.append(line.str());
  } catch (const std::exception& error) {
    std::cerr << "projtour: sim: " << error.what() << "; the projector log stops here\n";
    jsonl = AppendOnlyFile();
  }
}

}  // namespace projtour::sim
