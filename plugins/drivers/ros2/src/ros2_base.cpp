#include <algorithm>
#include <cmath>
#include <thread>

#include "projtour/contract/ground_truth.hpp"
#include "ros2_drivers.hpp"

namespace projtour::ros2 {

namespace {

double seconds_since(SteadyClock::time_point t) {
  return std::chrono::duration<double>(SteadyClock::now() - t).count();
}

// How long the first odometry may take: DDS discovery on a real network takes a second or two.
double startup_timeout_s(const Params& params) {
  return params.number("startup_timeout_s");
}

}  // namespace

std::string silence_reason(const Participant& p, const std::string& dds_topic,
                           const std::string& expected_type, const std::string& last_refusal) {
  if (!last_refusal.empty()) return "the last message was refused: " + last_refusal;
  const auto types = p.published_types(dds_topic);
  if (types.empty())
    return "nobody publishes " + dds_topic + " on DDS domain " +
           std::to_string(p.network().domain_id);
  for (const auto& t : types) {
    if (t == expected_type) return "its publisher sends nothing";
  }
  std::string list;
  for (const auto& t : types) list += (list.empty() ? "" : ", ") + t;
  return dds_topic + " is published as " + list + ", expected " + expected_type;
}

Ros2Base::Ros2Base(const Params& params, const RunContext& run)
    : run_(run),
      spec_(run.mission->robot.ros2),
      participant_(network_of(spec_), "projtour_base"),
      cmd_vel_(participant_, geometry_msgs_msg_dds__Twist__desc,
               dds_topic_name(spec_.ros2_namespace, spec_.cmd_vel.name),
               {spec_.cmd_vel.reliable, spec_.cmd_vel.depth, false}),
      odom_(participant_, nav_msgs_msg_dds__Odometry__desc,
            dds_topic_name(spec_.ros2_namespace, spec_.odom.name),
            {spec_.odom.reliable, spec_.odom.depth, false}) {
  if (run.dry_run) {
    clock_ = std::make_unique<Writer<rosgraph_msgs_msg_dds__Clock_>>(
        participant_, rosgraph_msgs_msg_dds__Clock__desc,
        dds_topic_name(spec_.ros2_namespace, "clock"), QosProfile{true, 10, false});
    truth_ = std::make_unique<Reader<geometry_msgs_msg_dds__PoseStamped_>>(
        participant_, geometry_msgs_msg_dds__PoseStamped__desc,
        dds_topic_name(spec_.ros2_namespace, "projtour_sim/true_pose"),
        QosProfile{true, 10, false});
    // The bridge answers each clock with the odometry of that instant: wait until it hears us.
    const auto deadline =
        SteadyClock::now() + std::chrono::duration<double>(startup_timeout_s(params));
    while (clock_->matched() == 0 && SteadyClock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (clock_->matched() == 0) {
      throw DriverError("base ros2_base: no simulator (projtour-sim-ros2) reads " +
                        clock_->topic() + " on DDS domain " + std::to_string(spec_.domain_id) +
                        " (start it with the same mission, world and seed)");
    }
  }
  // Nothing moves before the base is heard: a robot file naming the wrong topic or domain is an
  // error here, before the tour starts, not a robot that never arrives.
  if (!wait_for_first_odometry(startup_timeout_s(params))) {
    throw DriverError("base ros2_base: no valid odometry on " + odom_.topic() + " within " +
                      std::to_string(startup_timeout_s(params)) + " s: " +
                      silence_reason(participant_, odom_.topic(),
                                     nav_msgs_msg_dds__Odometry__desc.m_typename, last_refusal_));
  }
}

Ros2Base::~Ros2Base() {
  safe_stop();
}

void Ros2Base::drain_odometry() {
  odom_.take([&](const nav_msgs_msg_dds__Odometry_& msg, const dds_sample_info_t&) {
    const OdometryRead r = read_odometry(msg, spec_);
    std::lock_guard<std::mutex> lock(mutex_);
    if (!r.odometry) {
      if (refused_++ == 0 || r.refusal.reason != last_refusal_) {
        if (run_.log != nullptr) {
          run_.log->warning("base ros2_base: odometry refused on " + odom_.topic() + ": " +
                            r.refusal.reason);
        }
      }
      last_refusal_ = r.refusal.reason;
      return;
    }
    // Out of order (a best-effort QoS over a lossy link) never steps the pose back in time.
    if (odometry_ && r.odometry->t_s < odometry_->t_s) return;
    odometry_ = r.odometry;
    last_odometry_wall_ = SteadyClock::now();
    last_refusal_.clear();
  });
}

bool Ros2Base::wait_for_first_odometry(double timeout_s) {
  if (!clock_) return wait_for_odometry(0.0, timeout_s);
  // Discovery is not symmetric: our clock writer can match the bridge's reader before that
  // reader has matched the writer, and a volatile reader drops what came before its match.
  // The bridge does not step again for a time it has reached (it re-sends that instant's
  // odometry), and nothing is commanded before this returns: t = 0 is repeated until it answers.
  const auto deadline = SteadyClock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    clock_->write(rosgraph_msgs_msg_dds__Clock_{to_time(0.0)});
    const double left_s = std::chrono::duration<double>(deadline - SteadyClock::now()).count();
    if (wait_for_odometry(0.0, std::clamp(left_s, 0.0, 0.2))) return true;
    if (SteadyClock::now() >= deadline) return false;
  }
}

bool Ros2Base::wait_for_odometry(double at_least_t_s, double timeout_s) {
  const auto deadline = SteadyClock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    drain_odometry();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      // The bridge stamps odometry with the mission time it reached (to the nanosecond).
      if (odometry_ && odometry_->t_s >= at_least_t_s - 1e-6) return true;
    }
    if (SteadyClock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

void Ros2Base::update(double t_s) {
  if (clock_) {
    clock_->write(rosgraph_msgs_msg_dds__Clock_{to_time(t_s)});
    if (!wait_for_odometry(t_s, spec_.odom_timeout_s)) {
      stop_and_fail("no odometry of mission time " + std::to_string(t_s) + " s on " +
                    odom_.topic() + " within " + std::to_string(spec_.odom_timeout_s) + " s: " +
                    silence_reason(participant_, odom_.topic(),
                                   nav_msgs_msg_dds__Odometry__desc.m_typename, last_refusal_));
    }
    std::optional<Pose2D> true_pose;
    truth_->take([&](const geometry_msgs_msg_dds__PoseStamped_& msg, const dds_sample_info_t&) {
      const auto& q = msg.pose.orientation;
      true_pose =
          Pose2D{msg.pose.position.x, msg.pose.position.y,
                 std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))};
    });
    GroundTruth* truth = run_.drivers != nullptr ? run_.drivers->ground_truth() : nullptr;
    if (true_pose && truth != nullptr) truth->follow_true_base(*true_pose);
    return;
  }
  drain_odometry();
  double silent_s = 0.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    silent_s = seconds_since(last_odometry_wall_);
  }
  if (silent_s > spec_.odom_timeout_s) {
    stop_and_fail("no valid odometry on " + odom_.topic() + " for " + std::to_string(silent_s) +
                  " s (timeout " + std::to_string(spec_.odom_timeout_s) + " s): " +
                  silence_reason(participant_, odom_.topic(),
                                 nav_msgs_msg_dds__Odometry__desc.m_typename, last_refusal_));
  }
  if (failed_) {
    // Odometry is back: the base may move again, from what the machine commands next.
    if (run_.log != nullptr)
      run_.log->info("base ros2_base: odometry on " + odom_.topic() + " is back");
    std::lock_guard<std::mutex> lock(mutex_);
    failed_.reset();
  }
}

void Ros2Base::stop_and_fail(const std::string& why) {
  safe_stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!failed_) failed_ = why;
  }
  throw_failed();
}

void Ros2Base::throw_failed() const {
  throw DriverError("base ros2_base: robot stopped: " + *failed_);
}

void Ros2Base::command_velocity(double v_mps, double w_radps) {
  if (failed_) {
    safe_stop();
    throw_failed();
  }
  if (!std::isfinite(v_mps) || !std::isfinite(w_radps)) {
    safe_stop();
    throw DriverError("base ros2_base: velocity command is not finite (v " + std::to_string(v_mps) +
                      " m/s, w " + std::to_string(w_radps) + " rad/s); robot stopped");
  }
  const BaseSpec& base = run_.mission->robot.base;
  const double w_max = base.max_turn_rate_dps * M_PI / 180.0;
  cmd_vel_.write(make_twist(std::clamp(v_mps, -base.max_speed_mps, base.max_speed_mps),
                            std::clamp(w_radps, -w_max, w_max)));
}

Odometry Ros2Base::odometry() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return odometry_.value_or(Odometry{});
}

void Ros2Base::safe_stop() {
  // Only DDS writes, which are thread safe: the watchdog may call this while a tick is inside.
  const auto zero = make_twist(0.0, 0.0);
  for (int i = 0; i < spec_.stop_repeats; ++i) {
    try {
      cmd_vel_.write(zero);
    } catch (...) {  // must not throw; the next repeat may get through
    }
  }
}

}  // namespace projtour::ros2
