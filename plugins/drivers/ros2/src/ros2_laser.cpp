#include "ros2_drivers.hpp"

namespace projtour::ros2 {

Ros2Laser::Ros2Laser(const Params&, const RunContext& run)
    : run_(run),
      spec_(run.mission->robot.ros2),
      participant_(network_of(spec_), "projtour_laser"),
      scan_(participant_, sensor_msgs_msg_dds__LaserScan__desc,
            dds_topic_name(spec_.ros2_namespace, spec_.scan.name),
            {spec_.scan.reliable, spec_.scan.depth, false}) {}

std::optional<LaserScan> Ros2Laser::take_scan() {
  std::optional<LaserScan> newest;
  scan_.take([&](const sensor_msgs_msg_dds__LaserScan_& msg, const dds_sample_info_t&) {
    ScanRead r = read_scan(msg, spec_, run_.mission->robot.laser.T_base_laser);
    if (!r.scan) {
      if (r.refusal.reason != last_refusal_ && run_.log != nullptr) {
        run_.log->warning("laser ros2_laser: scan refused on " + scan_.topic() + ": " +
                          r.refusal.reason);
      }
      last_refusal_ = r.refusal.reason;
      return;
    }
    if (!newest || r.scan->t_s >= newest->t_s) newest = std::move(r.scan);
  });
  return newest;
}

}  // namespace projtour::ros2
