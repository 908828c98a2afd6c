// ROS 2 over DDS (issue 17): the round trip of one simulated tick through projtour-sim-ros2
// (cmd_vel and /clock out, the odometry of that instant back), and what the three ros2 drivers
// cost the tour's process when the robot's topics run at their usual rates. Everything runs on
// loopback (ROS_LOCALHOST_ONLY=1) on a DDS domain this process claims for itself.
//
// The peers run in child processes (the bridge, or this program started again with --peer), so
// the CPU time measured here is the drivers' side alone: the peer's is read from /proc.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <thread>

#include "projtour/host/mission_loader.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour_sim/sim_world.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/run_rig.hpp"
#include "projtour_test/temp_dir.hpp"
#include "ros2_drivers.hpp"

namespace projtour {
namespace {

using namespace ros2;
using namespace std::chrono_literals;

// The same lock files as the ROS 2 tests (tests/plugins/drivers/ros2/ros2_test_domain.hpp), so a
// benchmark run beside the test suite never shares a domain with a test; held until this process
// ends.
int claim_dds_domain() {
  const int start = static_cast<int>((::getpid() + 97) % 200);
  for (int i = 0; i < 200; ++i) {
    const int d = 1 + (start + i) % 200;
    const std::string file = "/tmp/projtour-test-dds-domain-" + std::to_string(d) + ".lock";
    const int fd = ::open(file.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return d;
    ::close(fd);
  }
  throw std::runtime_error("no free DDS domain (all 200 lock files held)");
}

double process_cpu_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Time on CPU of another process's threads (the first field of each /proc/PID/task/*/schedstat,
// in ns): finer than /proc/PID/stat's clock ticks, which at 100 Hz are 0.1 % of a core over 10 s.
double child_cpu_s(pid_t pid) {
  double total_ns = 0;
  std::error_code ec;
  for (const auto& task :
       std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    std::ifstream in(task.path() / "schedstat");
    double on_cpu_ns = 0;
    if (in >> on_cpu_ns) total_ns += on_cpu_ns;
  }
  return ec ? NAN : 1e-9 * total_ns;
}

// The latency at quantile q (0..1) of `samples_us`, which it reorders.
double quantile_us(std::vector<double>& samples_us, double q) {
  if (samples_us.empty()) return NAN;
  const auto k = static_cast<std::size_t>(
      std::min<double>(std::ceil(q * static_cast<double>(samples_us.size())) - 1,
                       static_cast<double>(samples_us.size() - 1)));
  std::nth_element(samples_us.begin(), samples_us.begin() + static_cast<long>(k), samples_us.end());
  return samples_us[k];
}

void report_latencies(benchmark::State& state, std::vector<double>& latencies_us) {
  state.counters["round_trips"] = static_cast<double>(latencies_us.size());
  state.counters["p50_us"] = quantile_us(latencies_us, 0.50);
  state.counters["p99_us"] = quantile_us(latencies_us, 0.99);
  state.counters["max_us"] = *std::max_element(latencies_us.begin(), latencies_us.end());
}

const std::string kMission = std::string(PROJTOUR_SOURCE_DIR) + "/missions/demo_tour.yaml";
const std::string kWorld = std::string(PROJTOUR_SOURCE_DIR) + "/missions/demo_world.yaml";
constexpr double kTick_s = 0.05;  // the executor's 20 Hz tick, the dry run's step

// The demo tour's robot on `domain`, loopback only: the topics and QoS the bridge uses too.
void load_demo(test::RunRig& rig, int domain) {
  rig.mission = host::load_mission_or_throw(kMission);
  rig.mission.robot.ros2.domain_id = domain;
  rig.mission.robot.ros2.loopback_only = true;
}

// The child's output goes to `logs` (gone with it, unless the benchmark failed).
test::ChildOptions bridge_options(int domain, const test::TempDir& logs) {
  test::ChildOptions o;
  o.stdout_file = logs / "bridge.stdout";
  o.stderr_file = logs / "bridge.stderr";
  o.argv = {PROJTOUR_SIM_ROS2, kMission, "--world", kWorld, "--seed", "1"};
  o.env["ROS_DOMAIN_ID"] = std::to_string(domain);
  o.env["ROS_LOCALHOST_ONLY"] = "1";
  return o;
}

void stop_child(test::Child& child) {
  child.signal(SIGTERM);  // the bridge leaves the domain cleanly on SIGTERM
  child.wait(std::chrono::milliseconds(5000));
}

// Spinning in place: the bridge's world moves (the laser sees new walls every scan) but never
// runs into one, however many ticks the benchmark takes.
constexpr double kSpin_radps = 0.5;

// Arg 0, the tour's path: Ros2Base in a dry run, each tick command_velocity() then update(t),
// which writes /clock and polls odom (every 200 us) until the odometry of t arrives, and takes
// the true pose. What one tick of `projtour run --dry-run --ros2-bridge` waits for the bridge.
// Arg 1, DDS's floor: the same messages written by hand and the odometry awaited on a waitset
// (woken by its arrival), no polling.
void bridge_round_trip(benchmark::State& state) {
  const bool through_driver = state.range(0) == 0;
  const int domain = claim_dds_domain();
  test::RunRig rig{test::RunRig::RunDir::none};
  load_demo(rig, domain);
  const test::TempDir logs("bench_ros2");
  test::Child bridge(bridge_options(domain, logs));
  std::vector<double> latencies_us;
  latencies_us.reserve(static_cast<std::size_t>(state.max_iterations));
  double t_s = 0.0;
  if (through_driver) {
    Params params;
    params.set("startup_timeout_s", ParamValue(20.0));
    Ros2Base base(params, rig.run);  // waits for the bridge and its first odometry
    for (auto _ : state) {
      t_s += kTick_s;
      const auto start = SteadyClock::now();
      base.command_velocity(0.0, kSpin_radps);
      base.update(t_s);
      latencies_us.push_back(
          std::chrono::duration<double, std::micro>(SteadyClock::now() - start).count());
      if (std::abs(base.odometry().t_s - t_s) > 1e-6) {
        state.SkipWithError("the odometry is not of the tick's time");
        break;
      }
    }
  } else {
    const Ros2Spec& spec = rig.mission.robot.ros2;
    Participant p(network_of(spec), "bench_round_trip");
    Writer<geometry_msgs_msg_dds__Twist_> cmd_vel(
        p, geometry_msgs_msg_dds__Twist__desc, dds_topic_name("", spec.cmd_vel.name),
        {spec.cmd_vel.reliable, spec.cmd_vel.depth, false});
    Writer<rosgraph_msgs_msg_dds__Clock_> clock(p, rosgraph_msgs_msg_dds__Clock__desc,
                                                dds_topic_name("", "clock"), {true, 10, false});
    Reader<nav_msgs_msg_dds__Odometry_> odom(p, nav_msgs_msg_dds__Odometry__desc,
                                             dds_topic_name("", spec.odom.name),
                                             {spec.odom.reliable, spec.odom.depth, false});
    // Read as the tour reads them, so the bridge sends what it sends in a tour.
    Reader<geometry_msgs_msg_dds__PoseStamped_> truth(p, geometry_msgs_msg_dds__PoseStamped__desc,
                                                      dds_topic_name("", "projtour_sim/true_pose"),
                                                      {true, 10, false});
    Reader<sensor_msgs_msg_dds__LaserScan_> scan(p, sensor_msgs_msg_dds__LaserScan__desc,
                                                 dds_topic_name("", spec.scan.name),
                                                 {spec.scan.reliable, spec.scan.depth, false});
    const dds_entity_t waitset = check(dds_create_waitset(p.handle()), "creating a waitset");
    const dds_entity_t arrived =
        check(dds_create_readcondition(odom.handle(), DDS_ANY_STATE), "creating a read condition");
    check(dds_waitset_attach(waitset, arrived, 0), "attaching the read condition");
    const auto deadline = SteadyClock::now() + 20s;
    while ((clock.matched() == 0 || cmd_vel.matched() == 0 || odom.matched() == 0 ||
            truth.matched() == 0 || scan.matched() == 0) &&
           SteadyClock::now() < deadline) {
      std::this_thread::sleep_for(5ms);
    }
    if (clock.matched() == 0 || odom.matched() == 0) {
      state.SkipWithError(
          ("projtour-sim-ros2 not heard on domain " + std::to_string(domain) + ": " + bridge.err())
              .c_str());
      stop_child(bridge);
      return;
    }
    double odom_t_s = -1.0;
    for (auto _ : state) {
      t_s += kTick_s;
      const auto start = SteadyClock::now();
      cmd_vel.write(make_twist(0.0, kSpin_radps));
      clock.write(rosgraph_msgs_msg_dds__Clock_{to_time(t_s)});
      while (odom_t_s < t_s - 1e-6) {
        if (check(dds_waitset_wait(waitset, nullptr, 0, DDS_SECS(5)), "waiting for odom") == 0) {
          break;
        }
        odom.take([&](const nav_msgs_msg_dds__Odometry_& m, const dds_sample_info_t&) {
          odom_t_s = from_time(m.header.stamp);
        });
      }
      latencies_us.push_back(
          std::chrono::duration<double, std::micro>(SteadyClock::now() - start).count());
      truth.take([](const geometry_msgs_msg_dds__PoseStamped_&, const dds_sample_info_t&) {});
      scan.take([](const sensor_msgs_msg_dds__LaserScan_&, const dds_sample_info_t&) {});
      if (odom_t_s < t_s - 1e-6) {
        state.SkipWithError("no odometry of the tick's time within 5 s");
        break;
      }
    }
    dds_delete(waitset);
  }
  stop_child(bridge);
  if (!latencies_us.empty()) report_latencies(state, latencies_us);
  state.counters["mission_s"] = t_s;
}
// A peer that never comes (the bridge failed to start, a domain taken over) is the benchmark's
// error, with the driver's reason, not an uncaught exception.
template <void (*body)(benchmark::State&)>
void reporting_errors(benchmark::State& state) {
  try {
    body(state);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
  }
}

void BM_BridgeRoundTrip(benchmark::State& state) {
  reporting_errors<bridge_round_trip>(state);
}
BENCHMARK(BM_BridgeRoundTrip)
    ->ArgName("raw_waitset")
    ->Arg(0)
    ->Arg(1)
    ->Iterations(10000)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

// The bridge's own work in a round trip, without DDS: the same world (demo tour and world, seed
// 1, the bridge's settings) stepped in process as projtour-sim-ros2 steps it for each /clock —
// wheels, the scan when due, the true pose and the odometry — 10,000 ticks of 0.05 s spinning in
// place. BM_BridgeRoundTrip less this is what DDS and the two processes add.
void BM_BridgeStepInProcess(benchmark::State& state) {
  host::Diagnostics diag;
  auto mission = host::load_mission(kMission, diag);
  std::optional<host::WorldSpec> world;
  if (mission) world = host::load_world(kWorld, *mission, diag);
  if (!mission || !world || diag.has_errors()) {
    state.SkipWithError(diag.format().c_str());
    return;
  }
  RunContext run;
  run.mission = &*mission;
  run.world = &*world;
  run.dry_run = true;
  run.seed = 1;
  run.map = navigation::load_occupancy_grid(mission->map);
  sim::SimWorld sim(run);
  sim.set_velocity_time_constant(0.1);
  sim.set_laser_occupancy_threshold(0.6);
  double t_s = 0.0;
  long scans = 0;
  for (auto _ : state) {
    t_s += kTick_s;
    sim.command_velocity(0.0, kSpin_radps);
    sim.advance(t_s);
    if (auto scan = sim.take_scan()) ++scans;
    benchmark::DoNotOptimize(pose2d_from_isometry(sim.true_T_map_base()));
    benchmark::DoNotOptimize(sim.odometry());
  }
  state.counters["scans"] = static_cast<double>(scans);
}
BENCHMARK(BM_BridgeStepInProcess)->Iterations(10000)->Unit(benchmark::kMicrosecond);

// --peer DOMAIN SCAN_HZ: the robot's side for BM_DriversAt20Hz, until SIGTERM. Odometry and
// joint states at 20 Hz, scans of 541 rays at SCAN_HZ (the UD's Hokuyo: 270 degrees in 0.5 degree
// steps), the head's joints following its last command at once (an ideal controller); cmd_vel
// and the head's commands are read, so the drivers' writes go somewhere.
volatile std::sig_atomic_t g_peer_stop = 0;
void on_peer_signal(int) {
  g_peer_stop = 1;
}

int run_peer(int domain, double scan_hz) {
  std::signal(SIGTERM, on_peer_signal);
  Ros2Spec spec;
  spec.domain_id = domain;
  spec.loopback_only = true;
  Participant p(network_of(spec), "bench_peer");
  Writer<nav_msgs_msg_dds__Odometry_> odom(p, nav_msgs_msg_dds__Odometry__desc,
                                           dds_topic_name("", spec.odom.name),
                                           {spec.odom.reliable, spec.odom.depth, false});
  Writer<sensor_msgs_msg_dds__LaserScan_> scan(p, sensor_msgs_msg_dds__LaserScan__desc,
                                               dds_topic_name("", spec.scan.name),
                                               {spec.scan.reliable, spec.scan.depth, false});
  Writer<sensor_msgs_msg_dds__JointState_> joints(
      p, sensor_msgs_msg_dds__JointState__desc, dds_topic_name("", spec.joint_states.name),
      {spec.joint_states.reliable, spec.joint_states.depth, false});
  Reader<geometry_msgs_msg_dds__Twist_> cmd_vel(p, geometry_msgs_msg_dds__Twist__desc,
                                                dds_topic_name("", spec.cmd_vel.name),
                                                {spec.cmd_vel.reliable, spec.cmd_vel.depth, false});
  Reader<std_msgs_msg_dds__Float64MultiArray_> head(
      p, std_msgs_msg_dds__Float64MultiArray__desc, dds_topic_name("", spec.pan_tilt_command.name),
      {spec.pan_tilt_command.reliable, spec.pan_tilt_command.depth, false});

  LaserScan s;
  s.angle_min_rad = -135.0 * M_PI / 180.0;
  s.angle_increment_rad = 0.5 * M_PI / 180.0;
  s.max_range_m = 20.0;
  s.ranges_m.resize(541);
  s.valid.assign(541, 1);
  Odometry o;
  JointAngles angles;
  OdometryMessage odom_msg;
  ScanMessage scan_msg;
  JointStateMessage joint_msg;
  const auto start = SteadyClock::now();
  auto next_20hz = start;
  auto next_scan = start;
  const auto scan_period = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(1.0 / scan_hz));
  while (!g_peer_stop) {
    const auto now = SteadyClock::now();
    const double t_s = std::chrono::duration<double>(now - start).count();
    cmd_vel.take([&](const geometry_msgs_msg_dds__Twist_& t, const dds_sample_info_t&) {
      o.v_mps = t.linear.x;
      o.w_radps = t.angular.z;
    });
    head.take([&](const std_msgs_msg_dds__Float64MultiArray_& m, const dds_sample_info_t&) {
      Refusal refusal;
      if (auto a = read_joint_command(m, refusal)) angles = *a;
    });
    if (now >= next_20hz) {
      o.pose.yaw_rad += o.w_radps * kTick_s;
      o.t_s = t_s;
      fill_odometry(o, spec, odom_msg);
      odom.write(odom_msg.msg);
      fill_joint_state(t_s, angles, spec, joint_msg);
      joints.write(joint_msg.msg);
      next_20hz += std::chrono::milliseconds(50);
    }
    if (now >= next_scan) {
      s.t_s = t_s;
      // A room of 3-5 m: ranges that change from scan to scan, as a turning robot's do.
      for (std::size_t i = 0; i < s.ranges_m.size(); ++i) {
        s.ranges_m[i] = static_cast<float>(4.0 + std::sin(0.02 * static_cast<double>(i) + t_s));
      }
      fill_scan(s, "laser", scan_msg);
      scan.write(scan_msg.msg);
      next_scan += scan_period;
    }
    std::this_thread::sleep_until(std::min(next_20hz, next_scan));
  }
  return 0;
}

// The three ros2 drivers as the tour's 20 Hz tick uses them, against a peer in a child process
// (--peer above) publishing odometry and joint states at 20 Hz and scans at Arg Hz. One
// iteration is `kSeconds` of ticks: base.update, base.command_velocity, laser.take_scan,
// pan_tilt.update, pan_tilt.command and the reads, then sleeping to the next tick. cpu_percent:
// this process's CPU time (CLOCK_PROCESS_CPUTIME_ID: the tick thread and Cyclone's receive and
// timer threads for the three participants) over the wall time, in % of one core; the peer's
// own, from its threads' /proc schedstat over the same interval, is peer_cpu_percent.
constexpr double kSeconds = 10.0;

void drivers_at_20hz(benchmark::State& state) {
  const int scan_hz = static_cast<int>(state.range(0));
  const int domain = claim_dds_domain();
  test::RunRig rig{test::RunRig::RunDir::none};
  load_demo(rig, domain);
  rig.run.dry_run = false;  // hardware: no /clock, the drivers read what the peer sends
  const test::TempDir logs("bench_ros2");
  test::ChildOptions o;
  o.stdout_file = logs / "peer.stdout";
  o.stderr_file = logs / "peer.stderr";
  char self[4096] = {0};
  if (::readlink("/proc/self/exe", self, sizeof(self) - 1) <= 0) {
    state.SkipWithError("cannot read /proc/self/exe to start the peer");
    return;
  }
  o.argv = {self, "--peer", std::to_string(domain), std::to_string(scan_hz)};
  test::Child peer(o);
  Params params;
  params.set("startup_timeout_s", ParamValue(20.0));
  Ros2Base base(params, rig.run);
  Ros2Laser laser(params, rig.run);
  Ros2PanTilt pan_tilt(params, rig.run);
  long scans = 0, ticks = 0;
  double cpu_s = 0, peer_cpu_s = 0, wall_s = 0;
  for (auto _ : state) {
    const double cpu0 = process_cpu_s(), peer0 = child_cpu_s(peer.pid());
    const auto start = SteadyClock::now();
    auto next = start;
    const long n = std::lround(kSeconds / kTick_s);
    for (long i = 0; i < n; ++i) {
      const double t_s = static_cast<double>(i) * kTick_s;
      base.update(t_s);
      pan_tilt.update(t_s);
      if (laser.take_scan()) ++scans;
      const Odometry odom = base.odometry();
      base.command_velocity(0.2, 0.1 * std::sin(t_s));
      const JointAngles a{0.5 * std::sin(0.2 * t_s), 0.3};
      pan_tilt.command(a);
      benchmark::DoNotOptimize(odom);
      benchmark::DoNotOptimize(pan_tilt.reached());
      ++ticks;
      next += std::chrono::milliseconds(50);
      std::this_thread::sleep_until(next);
    }
    wall_s += std::chrono::duration<double>(SteadyClock::now() - start).count();
    cpu_s += process_cpu_s() - cpu0;
    peer_cpu_s += child_cpu_s(peer.pid()) - peer0;
  }
  stop_child(peer);
  state.counters["cpu_percent"] = 100.0 * cpu_s / wall_s;
  state.counters["peer_cpu_percent"] = 100.0 * peer_cpu_s / wall_s;
  state.counters["cpu_us_per_tick"] = 1e6 * cpu_s / static_cast<double>(ticks);
  state.counters["scans_per_s"] = static_cast<double>(scans) / wall_s;
  state.counters["ticks"] = static_cast<double>(ticks);
}
void BM_DriversAt20Hz(benchmark::State& state) {
  reporting_errors<drivers_at_20hz>(state);
}
BENCHMARK(BM_DriversAt20Hz)
    ->ArgName("scan_hz")
    ->Arg(10)
    ->Arg(20)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace projtour

int main(int argc, char** argv) {
  if (argc == 4 && std::strcmp(argv[1], "--peer") == 0) {
    try {
      return projtour::run_peer(std::stoi(argv[2]), std::stod(argv[3]));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_ros2 --peer: %s\n", e.what());
      return 1;
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
