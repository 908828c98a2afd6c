// Drivers over ROS 2 (DDS): ros2_base, ros2_laser, ros2_pan_tilt. Their topics, namespace, QoS,
// domain and frames are the robot file's ros2 section (ROS 2's defaults where it is silent).
#include "projtour/contract/plugin_author.hpp"
#include "ros2_drivers.hpp"

namespace projtour {
namespace {

void check_startup(const Params& params) {
  const double t = params.number("startup_timeout_s");
  if (!(t > 0.0 && t <= 600.0))
    throw std::invalid_argument("startup_timeout_s must be in (0, 600]");
}

const projtour_param_desc kStartup[] = {
    {"startup_timeout_s", "number", "5",
     "wall seconds the first message may take (DDS discovery) before the run ends unmoved"}};

const projtour_kind_desc kKinds[] = {
    driver_kind<ros2::Ros2Base>(
        "ros2_base", "base",
        "mobile base over ROS 2: geometry_msgs/Twist on cmd_vel, nav_msgs/Odometry from odom",
        kStartup, validator<check_startup>()),
    driver_kind<ros2::Ros2Laser>("ros2_laser", "laser",
                                 "2-D laser over ROS 2: sensor_msgs/LaserScan from scan", kStartup,
                                 validator<check_startup>()),
    driver_kind<ros2::Ros2PanTilt>(
        "ros2_pan_tilt", "pan_tilt",
        "pan-tilt over ROS 2: std_msgs/Float64MultiArray commands, sensor_msgs/JointState",
        kStartup, validator<check_startup>())};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("ros2", "1.0.0", projtour::kKinds)
