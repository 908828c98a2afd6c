// projtour-sim-ros2: the simulated base and laser of a dry run behind ROS 2 topics, so that a
// tour can run its ros2_* drivers over DDS against the simulator (projtour run --dry-run
// --ros2-bridge). It steps the same world a dry run would (same mission, world file and seed)
// to each mission time the tour publishes on clock (under the namespace): for each, the latest
// cmd_vel drives the simulated wheels, then the scan (when one is due), the true base pose (for the
// tour's own simulated cameras and projector, never for its behaviours) and last the odometry of
// that instant go out, the odometry telling the tour that the step is done.
#include <cmath>
#include <csignal>
#include <iostream>
#include <thread>

#include "projtour/cli/options.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/world.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/ros2/dds.hpp"
#include "projtour/ros2/messages.hpp"
#include "projtour_sim/sim_world.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) {
  g_stop = 1;
}

using namespace projtour;
using namespace projtour::ros2;

int run_bridge(const std::filesystem::path& mission_file,
               const std::optional<std::filesystem::path>& world_file, std::uint64_t seed,
               double idle_exit_s) {
  host::Diagnostics diag;
  auto mission = host::load_mission(mission_file, diag);
  std::optional<host::WorldSpec> world;
  if (mission && world_file) world = host::load_world(*world_file, *mission, diag);
  if (diag.has_errors() || !mission) {
    std::cerr << diag.format();
    return 2;
  }
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  try {
    map = navigation::load_occupancy_grid(mission->map);
  } catch (const std::exception& e) {
    std::cerr << "projtour-sim-ros2: " << e.what() << "\n";
    return 2;
  }
  const Ros2Spec& spec = mission->robot.ros2;
  RunContext run;
  run.mission = &*mission;
  run.world = world ? &*world : nullptr;
  run.dry_run = true;
  run.seed = seed;
  run.map = map;
  sim::SimWorld sim(run);
  // The dry run's own drivers' defaults (sim plugin's parameter schema).
  sim.set_velocity_time_constant(0.1);
  sim.set_laser_occupancy_threshold(0.6);

  Participant participant(network_of(spec), "projtour_sim");
  Reader<rosgraph_msgs_msg_dds__Clock_> clock(participant, rosgraph_msgs_msg_dds__Clock__desc,
                                              dds_topic_name(spec.ros2_namespace, "clock"),
                                              {true, 100, false});
  Reader<geometry_msgs_msg_dds__Twist_> cmd_vel(
      participant, geometry_msgs_msg_dds__Twist__desc,
      dds_topic_name(spec.ros2_namespace, spec.cmd_vel.name),
      {spec.cmd_vel.reliable, spec.cmd_vel.depth, false});
  Writer<nav_msgs_msg_dds__Odometry_> odom(participant, nav_msgs_msg_dds__Odometry__desc,
                                           dds_topic_name(spec.ros2_namespace, spec.odom.name),
                                           {spec.odom.reliable, spec.odom.depth, false});
  Writer<sensor_msgs_msg_dds__LaserScan_> scan(participant, sensor_msgs_msg_dds__LaserScan__desc,
                                               dds_topic_name(spec.ros2_namespace, spec.scan.name),
                                               {spec.scan.reliable, spec.scan.depth, false});
  Writer<geometry_msgs_msg_dds__PoseStamped_> truth(
      participant, geometry_msgs_msg_dds__PoseStamped__desc,
      dds_topic_name(spec.ros2_namespace, "projtour_sim/true_pose"), {true, 10, false});
  const std::string laser_frame = spec.laser_frame.empty() ? "laser" : spec.laser_frame;
  std::cerr << "projtour-sim-ros2: " << mission->name << " on DDS domain " << spec.domain_id
            << (spec.loopback_only ? " (loopback only)" : "") << ", waiting for " << clock.topic()
            << "\n";

  double last_v = 0.0, last_w = 0.0;
  long steps = 0;
  auto last_clock_wall = std::chrono::steady_clock::now();
  OdometryMessage odom_msg;
  ScanMessage scan_msg;
  std::string map_frame = "map";
  while (!g_stop) {
    bool stepped = false;
    clock.take([&](const rosgraph_msgs_msg_dds__Clock_& c, const dds_sample_info_t&) {
      const double t_s = from_time(c.clock);
      cmd_vel.take([&](const geometry_msgs_msg_dds__Twist_& t, const dds_sample_info_t&) {
        // A real base ignores a command it cannot execute; so does this one.
        if (std::isfinite(t.linear.x) && std::isfinite(t.angular.z)) {
          last_v = t.linear.x;
          last_w = t.angular.z;
        }
      });
      sim.command_velocity(last_v, last_w);
      sim.advance(t_s);
      if (auto s = sim.take_scan()) {
        fill_scan(*s, laser_frame, scan_msg);
        scan.write(scan_msg.msg);
      }
      const Pose2D p = pose2d_from_isometry(sim.true_T_map_base());
      geometry_msgs_msg_dds__PoseStamped_ pose{};
      pose.header.stamp = to_time(t_s);
      pose.header.frame_id = map_frame.data();
      pose.pose.position.x = p.x_m;
      pose.pose.position.y = p.y_m;
      pose.pose.orientation = quaternion_from_yaw(p.yaw_rad);
      truth.write(pose);
      Odometry o = sim.odometry();
      o.t_s = std::max(o.t_s, t_s);  // the instant asked for, even before the world started
      fill_odometry(o, spec, odom_msg);
      odom.write(odom_msg.msg);
      ++steps;
      stepped = true;
    });
    const auto now = std::chrono::steady_clock::now();
    if (stepped) {
      last_clock_wall = now;
    } else {
      if (idle_exit_s > 0 && steps > 0 &&
          std::chrono::duration<double>(now - last_clock_wall).count() > idle_exit_s) {
        break;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  }
  std::cerr << "projtour-sim-ros2: stopped after " << steps << " steps\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("projtour-sim-ros2: the simulated base and laser of a dry run, as a ROS 2 robot",
               "projtour-sim-ros2");
  std::string mission;
  std::optional<std::filesystem::path> world;
  std::uint64_t seed = 1;
  double idle_exit_s = 0.0;
  app.add_option("mission", mission, "MISSION.yaml")->required();
  app.add_option_function<std::string>(
      "--world", [&](const std::string& w) { world = w; }, "the dry run's world file");
  projtour::cli::add_uint64(
      app, "--seed", [&](std::uint64_t s) { seed = s; }, "N");
  projtour::cli::add_finite(
      app, "--idle-exit-s", [&](double s) { idle_exit_s = s; },
      [](double s) { return s < 0 ? std::string("must be >= 0") : std::string(); }, "S");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    return run_bridge(mission, world, seed, idle_exit_s);
  } catch (const std::exception& e) {
    std::cerr << "projtour-sim-ros2: " << e.what() << "\n";
    return 1;
  }
}
