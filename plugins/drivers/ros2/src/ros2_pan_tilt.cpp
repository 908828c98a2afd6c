#include <cmath>
#include <thread>

#include "ros2_drivers.hpp"

namespace projtour::ros2 {

Ros2PanTilt::Ros2PanTilt(const Params& params, const RunContext& run)
    : run_(run),
      spec_(run.mission->robot.ros2),
      tolerance_rad_(run.mission->robot.pan_tilt.tolerance_deg * M_PI / 180.0),
      participant_(network_of(spec_), "projtour_pan_tilt"),
      command_(participant_, std_msgs_msg_dds__Float64MultiArray__desc,
               dds_topic_name(spec_.ros2_namespace, spec_.pan_tilt_command.name),
               {spec_.pan_tilt_command.reliable, spec_.pan_tilt_command.depth, false}),
      joint_states_(participant_, sensor_msgs_msg_dds__JointState__desc,
                    dds_topic_name(spec_.ros2_namespace, spec_.joint_states.name),
                    {spec_.joint_states.reliable, spec_.joint_states.depth, false}) {
  const double timeout_s = params.number("startup_timeout_s");
  const auto deadline = SteadyClock::now() + std::chrono::duration<double>(timeout_s);
  while (!has_measurement_ && SteadyClock::now() < deadline) {
    drain();
    if (!has_measurement_) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (!has_measurement_) {
    throw DriverError("pan_tilt ros2_pan_tilt: no joint state with joints \"" + spec_.pan_joint +
                      "\" and \"" + spec_.tilt_joint + "\" on " + joint_states_.topic() +
                      " within " + std::to_string(timeout_s) + " s: " +
                      silence_reason(participant_, joint_states_.topic(),
                                     sensor_msgs_msg_dds__JointState__desc.m_typename,
                                     last_refusal_));
  }
}

void Ros2PanTilt::drain() {
  joint_states_.take([&](const sensor_msgs_msg_dds__JointState_& msg, const dds_sample_info_t&) {
    const JointsRead r = read_joints(msg, spec_);
    std::lock_guard<std::mutex> lock(mutex_);
    if (!r.angles) {
      if (!r.refusal.reason.empty()) {
        if (r.refusal.reason != last_refusal_ && run_.log != nullptr) {
          run_.log->warning("pan_tilt ros2_pan_tilt: joint state refused on " +
                            joint_states_.topic() + ": " + r.refusal.reason);
        }
        last_refusal_ = r.refusal.reason;
      }
      return;
    }
    previous_ = has_measurement_ ? measured_ : *r.angles;
    measured_ = *r.angles;
    has_measurement_ = true;
    last_state_wall_ = SteadyClock::now();
  });
}

void Ros2PanTilt::update(double) {
  drain();
  const double silent_s =
      std::chrono::duration<double>(SteadyClock::now() - last_state_wall_).count();
  if (silent_s > spec_.odom_timeout_s) {
    safe_stop();
    throw DriverError("pan_tilt ros2_pan_tilt: no joint state on " + joint_states_.topic() +
                      " for " + std::to_string(silent_s) + " s: " +
                      silence_reason(participant_, joint_states_.topic(),
                                     sensor_msgs_msg_dds__JointState__desc.m_typename,
                                     last_refusal_));
  }
}

void Ros2PanTilt::command(const JointAngles& angles) {
  if (!std::isfinite(angles.pan_rad) || !std::isfinite(angles.tilt_rad)) {
    throw DriverError("pan_tilt ros2_pan_tilt: joint command is not finite");
  }
  const PanTiltSpec& head = run_.mission->robot.pan_tilt;
  const JointAngles limited{
      std::clamp(angles.pan_rad, head.pan_min_deg * M_PI / 180.0, head.pan_max_deg * M_PI / 180.0),
      std::clamp(angles.tilt_rad, head.tilt_min_deg * M_PI / 180.0,
                 head.tilt_max_deg * M_PI / 180.0)};
  JointCommandMessage msg;
  fill_joint_command(limited, msg);
  command_.write(msg.msg);
  std::lock_guard<std::mutex> lock(mutex_);
  commanded_ = limited;
  has_command_ = true;
}

JointAngles Ros2PanTilt::measured() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return measured_;
}

bool Ros2PanTilt::reached() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!has_command_) return true;
  return std::abs(measured_.pan_rad - commanded_.pan_rad) <= tolerance_rad_ &&
         std::abs(measured_.tilt_rad - commanded_.tilt_rad) <= tolerance_rad_ &&
         std::abs(measured_.pan_rad - previous_.pan_rad) <= tolerance_rad_ / 4 &&
         std::abs(measured_.tilt_rad - previous_.tilt_rad) <= tolerance_rad_ / 4;
}

void Ros2PanTilt::safe_stop() {
  // Holding still is commanding where the head is now.
  JointAngles hold;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!has_measurement_) return;
    hold = measured_;
  }
  try {
    JointCommandMessage msg;
    fill_joint_command(hold, msg);
    command_.write(msg.msg);
  } catch (...) {  // must not throw
  }
}

}  // namespace projtour::ros2
