// projtour's ros2 drivers against a ROS 2 node that is not built on Cyclone DDS: the Node.js
// peer of tests/ros2_peer (@foxglove/ros2 and @foxglove/rtps, RTPS in TypeScript). What the
// drivers read is what that peer encoded, and what they send is what it decoded: a wire format,
// a type name or a QoS that only Cyclone agrees with would fail here.
//
// The peer's messages are functions of their index k (peer.mjs): odom k is stamped
// 1000 + k s and 987654321 - k ns, at x = 1.5 + 0.25 k, y = -2.75, yaw 0.625 rad, 0.375 m/s and
// -0.125 rad/s, frames odom / base_link; scan k is stamped 2000 + k s and 250000000 + k ns, frame
// laser, 13 readings from -1.5 rad by 0.25 rad, 0.5 + 0.25 i + 0.125 (k % 4) m, with +inf at 3,
// NaN at 7 and one below range_min at 10. Every value is exact in binary, so they are compared
// for equality.
//
// @foxglove/ros2 only subscribes and @foxglove/rtps takes no endpoint that leaves out its
// reliability: the peer adds publishing and RTPS's default (peer.mjs says how and why).
//
// Needs node (CMake finds it) and tests/ros2_peer/node_modules (`make test` runs npm ci there);
// without them the test fails and says so: it is never skipped.
#include <dds/dds.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "projtour_test/process.hpp"
#include "projtour_test/run_rig.hpp"
#include "ros2_drivers.hpp"
#include "ros2_test_domain.hpp"

namespace projtour::ros2 {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;
using nlohmann::json;

const std::filesystem::path kPeerDir =
    std::filesystem::path(PROJTOUR_SOURCE_DIR) / "tests/ros2_peer";

// The local addresses ("127.0.0.1:PORT") of the UDP sockets process `pid` holds, from its fds
// and /proc/net/udp (IPv4) and udp6.
std::vector<std::string> udp_sockets_of(pid_t pid, std::vector<std::string>& udp6) {
  std::set<std::string> inodes;
  const std::string fd_dir = "/proc/" + std::to_string(pid) + "/fd";
  for (const auto& e : std::filesystem::directory_iterator(fd_dir)) {
    std::error_code ec;
    const std::string target = std::filesystem::read_symlink(e.path(), ec).string();
    if (!ec && target.rfind("socket:[", 0) == 0) inodes.insert(target.substr(8, target.size() - 9));
  }
  auto scan = [&](const std::string& file, bool v4) {
    std::vector<std::string> out;
    std::ifstream in(file);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::istringstream words(line);
      std::string sl, local, remote, st, queues, timer, retr, uid, timeout, inode;
      words >> sl >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode;
      if (inodes.count(inode) == 0) continue;
      if (!v4) {
        out.push_back(local);
        continue;
      }
      // HHHHHHHH:PPPP, the address in host (little-endian) byte order.
      const unsigned long a = std::stoul(local.substr(0, 8), nullptr, 16);
      const unsigned long port = std::stoul(local.substr(9), nullptr, 16);
      out.push_back(std::to_string(a & 0xff) + "." + std::to_string((a >> 8) & 0xff) + "." +
                    std::to_string((a >> 16) & 0xff) + "." + std::to_string((a >> 24) & 0xff) +
                    ":" + std::to_string(port));
    }
    return out;
  };
  udp6 = scan("/proc/net/udp6", false);
  return scan("/proc/net/udp", true);
}

class NodePeer {
 public:
  NodePeer(int domain, double duration_s) : child_(options(domain, duration_s)) {}

  // Every JSON line the peer printed so far.
  std::vector<json> lines() const {
    std::vector<json> out;
    std::istringstream in(child_.out());
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty()) continue;
      out.push_back(json::parse(line));
    }
    return out;
  }
  std::vector<json> events(const std::string& kind) const {
    std::vector<json> out;
    for (auto& l : lines()) {
      if (l.value("event", "") == kind) out.push_back(l);
    }
    return out;
  }
  // Waits until `done` holds of the lines; false past `limit` or when the peer exited first.
  bool wait_for(const std::function<bool(const NodePeer&)>& done,
                std::chrono::milliseconds limit = 10000ms) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (!done(*this)) {
      if (child_.poll() || std::chrono::steady_clock::now() > end) return done(*this);
      std::this_thread::sleep_for(5ms);
    }
    return true;
  }
  // Twists received, as (linear, angular) JSON objects, in order.
  std::vector<json> twists() const { return events("cmd_vel"); }

  test::Child& child() { return child_; }
  std::string err() const { return child_.err(); }

  // SIGTERM; the peer's last line: what it sent, received and refused to send.
  json finish() {
    if (!child_.poll()) child_.signal(SIGTERM);
    const int status = child_.wait(10000ms);
    EXPECT_EQ(status, 0) << "peer.mjs stderr:\n" << child_.err();
    const auto end = events("end");
    EXPECT_EQ(end.size(), 1u) << child_.out() << child_.err();
    return end.empty() ? json::object() : end.back();
  }

 private:
  static test::ChildOptions options(int domain, double duration_s) {
    test::ChildOptions o;
    o.argv = {PROJTOUR_NODE,  (kPeerDir / "peer.mjs").string(), "--domain",  std::to_string(domain),
              "--duration-s", std::to_string(duration_s),       "--rate-hz", "20"};
    // PROJTOUR_ROS2_PEER_ARGS: more of peer.mjs's options, to see the library as it is
    // ("--no-qos-defaults", "--subscribe-via rosnode") fail against the drivers.
    if (const char* more = std::getenv("PROJTOUR_ROS2_PEER_ARGS")) {
      for (auto& w : test::shell_words(more)) o.argv.push_back(w);
    }
    return o;
  }
  test::Child child_;
};

class FoxglovePeer : public ::testing::Test {
 protected:
  FoxglovePeer() {
    Ros2Spec& spec = rig.mission.robot.ros2;
    spec.domain_id = test::claim_dds_domain();
    spec.loopback_only = true;
    spec.laser_frame = "laser";
    spec.odom_timeout_s = 0.5;
    rig.run.dry_run = false;  // hardware: no /clock, wall-time timeouts, as on a robot
    Eigen::Isometry3d T_base_laser = Eigen::Isometry3d::Identity();
    T_base_laser.translate(Eigen::Vector3d(0.25, -0.125, 0.375));
    T_base_laser.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
    rig.mission.robot.laser.T_base_laser = T_base_laser;
    // Discovery between two implementations that both start now.
    params.set("startup_timeout_s", ParamValue(10.0));
  }

  const Ros2Spec& spec() const { return rig.mission.robot.ros2; }

  // The peer, running and on loopback only; null (with the test failed) when it cannot run.
  std::unique_ptr<NodePeer> start_peer(double duration_s = 25.0) {
    const std::string node = PROJTOUR_NODE;
    if (node.empty()) {
      ADD_FAILURE() << "node (Node.js) was not found when the build was configured: install "
                       "nodejs and re-run cmake; this test needs it and is never skipped";
      return nullptr;
    }
    if (!std::filesystem::exists(kPeerDir / "node_modules/@foxglove/ros2/package.json")) {
      ADD_FAILURE() << kPeerDir / "node_modules"
                    << " has no @foxglove/ros2: run `npm ci --prefix tests/ros2_peer` (make test "
                       "does); this test needs it and is never skipped";
      return nullptr;
    }
    auto peer = std::make_unique<NodePeer>(spec().domain_id, duration_s);
    if (!peer->wait_for([](const NodePeer& p) { return !p.events("ready").empty(); })) {
      ADD_FAILURE() << "peer.mjs did not start:\n" << peer->child().out() << peer->err();
      return nullptr;
    }
    std::vector<std::string> udp6;
    const auto udp4 = udp_sockets_of(peer->child().pid(), udp6);
    EXPECT_FALSE(udp4.empty());
    for (const auto& a : udp4) EXPECT_EQ(a.rfind("127.0.0.1:", 0), 0u) << a;
    EXPECT_TRUE(udp6.empty()) << udp6.front();
    return peer;
  }

  // Cyclone (this process's domain) has discovered the peer's reader of rt/cmd_vel, so the
  // base's writer is matched with it, and the peer has discovered the base's writer, so what it
  // receives from it is delivered: only then is a command sure to reach it.
  bool cmd_vel_matched(NodePeer& peer) {
    Participant watcher(network_of(spec()), "watcher");
    const dds_entity_t subs =
        dds_create_reader(watcher.handle(), DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
    if (subs < 0) return false;
    const auto end = std::chrono::steady_clock::now() + 10s;
    bool found = false;
    while (!found && std::chrono::steady_clock::now() < end) {
      void* samples[32] = {nullptr};
      dds_sample_info_t infos[32];
      const dds_return_t n = dds_read(subs, samples, infos, 32, 32);
      for (dds_return_t i = 0; i < n; ++i) {
        const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
        if (infos[i].valid_data && e->topic_name != nullptr &&
            std::string(e->topic_name) == "rt/cmd_vel" && e->type_name != nullptr &&
            std::string(e->type_name) == "geometry_msgs::msg::dds_::Twist_") {
          found = true;
        }
      }
      if (n > 0) dds_return_loan(subs, samples, n);
      if (!found) std::this_thread::sleep_for(5ms);
    }
    if (!found) return false;
    return peer.wait_for([](const NodePeer& p) {
      for (const auto& e : p.events("publication")) {
        if (e.value("topic", "") == "rt/cmd_vel") return true;
      }
      return false;
    });
  }

  // The peer's end: it ran on loopback only (no send to any other address was even tried).
  void finish(NodePeer& peer) {
    const json end = peer.finish();
    EXPECT_EQ(end.value("refused_sends", -1), 0) << peer.err();
    // For the log: the endpoints whose discovery data the peer read with RTPS's default
    // reliability filled in (peer.mjs says why), and its own count of what went each way.
    for (const auto& e : peer.events("qos_default")) std::cout << "peer: " << e.dump() << "\n";
    std::cout << "peer: " << end.dump() << "\n";
  }

  test::RunRig rig{test::RunRig::RunDir::none};
  Params params;
};

TEST_F(FoxglovePeer, BaseReadsTheOdometryItSent) {
  auto peer = start_peer();
  ASSERT_TRUE(peer);
  Ros2Base base(params, rig.run);  // waits for the first valid odometry
  long last_k = -1;
  for (int round = 0; round < 3; ++round) {
    // The newest odometry, once a newer one than the last round's came.
    Odometry o;
    long sec = 0, k = -1;
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    do {
      std::this_thread::sleep_for(20ms);
      base.update(0.0);
      o = base.odometry();
      sec = static_cast<long>(std::floor(o.t_s));
      k = sec - 1000;
    } while (k <= last_k && std::chrono::steady_clock::now() < deadline);
    ASSERT_GT(k, last_k) << "odometry stopped coming: t " << o.t_s << " s\n" << peer->err();
    ASSERT_LT(k, 10000) << o.t_s;
    last_k = k;
    // The stamp to the nanosecond.
    EXPECT_EQ(std::llround((o.t_s - static_cast<double>(sec)) * 1e9), 987654321 - k);
    EXPECT_EQ(o.t_s, static_cast<double>(sec) + static_cast<double>(987654321 - k) * 1e-9);
    EXPECT_EQ(o.pose.x_m, 1.5 + 0.25 * static_cast<double>(k));
    EXPECT_EQ(o.pose.y_m, -2.75);
    EXPECT_NEAR(o.pose.yaw_rad, 0.625, 1e-15);  // from the quaternion (sin, cos of 0.3125)
    EXPECT_EQ(o.v_mps, 0.375);
    EXPECT_EQ(o.w_radps, -0.125);
  }
  EXPECT_THAT(rig.log.messages(LogLevel::warning), testing::IsEmpty());  // nothing refused
  finish(*peer);
}

TEST_F(FoxglovePeer, LaserReadsTheScanItSent) {
  auto peer = start_peer();
  ASSERT_TRUE(peer);
  Ros2Laser laser(params, rig.run);
  std::vector<LaserScan> scans;
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (scans.size() < 3 && std::chrono::steady_clock::now() < end) {
    if (auto s = laser.take_scan()) scans.push_back(std::move(*s));
    std::this_thread::sleep_for(60ms);
  }
  ASSERT_EQ(scans.size(), 3u) << "scans heard from the peer within 10 s\n" << peer->err();
  long last_k = -1;
  for (const LaserScan& s : scans) {
    const long sec = static_cast<long>(std::floor(s.t_s));
    const long k = sec - 2000;
    ASSERT_GE(k, 0) << s.t_s;
    EXPECT_GT(k, last_k);
    last_k = k;
    EXPECT_EQ(std::llround((s.t_s - static_cast<double>(sec)) * 1e9), 250000000 + k);
    EXPECT_EQ(s.angle_min_rad, -1.5);
    EXPECT_EQ(s.angle_increment_rad, 0.25);
    EXPECT_EQ(s.max_range_m, 25.0);
    EXPECT_TRUE(s.T_base_laser.matrix() == rig.mission.robot.laser.T_base_laser.matrix());
    ASSERT_EQ(s.ranges_m.size(), 13u);
    ASSERT_EQ(s.valid.size(), 13u);
    for (std::size_t i = 0; i < 13; ++i) {
      SCOPED_TRACE("reading " + std::to_string(i) + " of scan " + std::to_string(k));
      if (i == 3 || i == 7 || i == 10) {  // +inf, NaN, below range_min
        EXPECT_EQ(s.valid[i], 0);
        EXPECT_EQ(s.ranges_m[i], 0.0f);
      } else {
        EXPECT_EQ(s.valid[i], 1);
        EXPECT_EQ(s.ranges_m[i],
                  0.5f + 0.25f * static_cast<float>(i) + 0.125f * static_cast<float>(k % 4));
      }
    }
  }
  EXPECT_THAT(rig.log.messages(LogLevel::warning), testing::IsEmpty());  // nothing refused
  finish(*peer);
}

TEST_F(FoxglovePeer, ItReceivesTheTwistsTheBaseSentAndTheSafeStop) {
  auto peer = start_peer();
  ASSERT_TRUE(peer);
  Ros2Base base(params, rig.run);
  ASSERT_TRUE(cmd_vel_matched(*peer)) << peer->child().out() << peer->err();
  const double w_max = rig.mission.robot.base.max_turn_rate_dps * M_PI / 180.0;
  const double v_max = rig.mission.robot.base.max_speed_mps;
  struct Twist2D {
    double v, w;
  };
  const std::vector<Twist2D> commands = {{0.2, -0.1}, {0.45, 0.5}, {-0.3, 0.0}, {5.0, 3.0}};
  std::vector<Twist2D> expected = {{0.2, -0.1}, {0.45, 0.5}, {-0.3, 0.0}, {v_max, w_max}};
  for (const auto& c : commands) base.command_velocity(c.v, c.w);
  base.safe_stop();
  for (int i = 0; i < spec().stop_repeats; ++i) expected.push_back({0.0, 0.0});
  ASSERT_TRUE(peer->wait_for([&](const NodePeer& p) {
    return p.twists().size() >= expected.size();
  })) << peer->child().out()
      << peer->err();
  std::this_thread::sleep_for(300ms);  // nothing more, nothing twice
  const auto got = peer->twists();
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE("twist " + std::to_string(i) + ": " + got[i].dump());
    EXPECT_EQ(got[i]["linear"]["x"].get<double>(), expected[i].v);
    EXPECT_EQ(got[i]["angular"]["z"].get<double>(), expected[i].w);
    for (const char* zero : {"y", "z"}) EXPECT_EQ(got[i]["linear"][zero].get<double>(), 0.0);
    for (const char* zero : {"x", "y"}) EXPECT_EQ(got[i]["angular"][zero].get<double>(), 0.0);
  }
  finish(*peer);
}

TEST_F(FoxglovePeer, WhenItsOdometryStopsTheBaseStopsTheRobotAndFails) {
  auto peer = start_peer();
  ASSERT_TRUE(peer);
  Ros2Base base(params, rig.run);
  ASSERT_TRUE(cmd_vel_matched(*peer)) << peer->child().out() << peer->err();
  base.update(0.0);
  base.command_velocity(0.25, 0.125);
  ASSERT_TRUE(peer->wait_for([](const NodePeer& p) { return p.twists().size() == 1; }));
  peer->child().signal(SIGUSR1);  // the peer stops odom and keeps listening to cmd_vel
  ASSERT_TRUE(peer->wait_for([](const NodePeer& p) { return !p.events("odom_stopped").empty(); }));
  const auto stopped = std::chrono::steady_clock::now();
  // Ticks at 50 Hz, as the executor's loop: the base measures silence from the last tick that
  // took odometry, so odometry sent before the stop and taken by a later tick counts as heard
  // then. It fails within the timeout (and a tick or two) of the stop, never before.
  std::string error;
  double failed_after_s = 0.0;
  for (int tick = 1; error.empty() && tick <= 150; ++tick) {
    std::this_thread::sleep_for(20ms);
    try {
      base.update(0.02 * tick);
    } catch (const DriverError& e) {
      error = e.what();
      failed_after_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - stopped).count();
    }
  }
  ASSERT_FALSE(error.empty()) << "no DriverError within 3 s of the odometry's stop";
  std::cout << "base failed " << failed_after_s << " s after the peer's odometry stopped\n";
  EXPECT_GE(failed_after_s, spec().odom_timeout_s - 0.06);  // at most one message before
  EXPECT_THAT(error, HasSubstr("robot stopped: no valid odometry on rt/odom for"));
  // The peer's publication is still announced, it just sends nothing.
  EXPECT_THAT(error, HasSubstr("its publisher sends nothing"));
  const std::size_t want = 1 + static_cast<std::size_t>(spec().stop_repeats);
  ASSERT_TRUE(peer->wait_for([&](const NodePeer& p) { return p.twists().size() >= want; }))
      << peer->child().out();
  // A command meanwhile is refused with another stop, never passed on.
  EXPECT_THROW(base.command_velocity(0.25, 0.0), DriverError);
  ASSERT_TRUE(peer->wait_for(
      [&](const NodePeer& p) {
        return p.twists().size() >= want + static_cast<std::size_t>(spec().stop_repeats);
      },
      3000ms));
  std::this_thread::sleep_for(200ms);
  const auto got = peer->twists();
  EXPECT_EQ(got.size(), want + static_cast<std::size_t>(spec().stop_repeats));
  EXPECT_EQ(got.front()["linear"]["x"].get<double>(), 0.25);
  EXPECT_EQ(got.front()["angular"]["z"].get<double>(), 0.125);
  for (std::size_t i = 1; i < got.size(); ++i) {
    EXPECT_EQ(got[i]["linear"]["x"].get<double>(), 0.0) << got[i].dump();
    EXPECT_EQ(got[i]["angular"]["z"].get<double>(), 0.0) << got[i].dump();
  }
  finish(*peer);
}

}  // namespace
}  // namespace projtour::ros2
