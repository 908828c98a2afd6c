// The ros2 drivers against a peer on the same loopback domain: what they read, what they send,
// and what they do when the other side sends nonsense, floods, or goes away.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "projtour_test/run_rig.hpp"
#include "ros2_drivers.hpp"
#include "ros2_test_domain.hpp"

namespace projtour::ros2 {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;

struct Peer {
  explicit Peer(const Ros2Spec& spec)
      : participant({spec.domain_id, true}, "test_peer"),
        odom(participant, nav_msgs_msg_dds__Odometry__desc, dds_topic_name("", "odom"),
             {true, 10, false}),
        scan(participant, sensor_msgs_msg_dds__LaserScan__desc, dds_topic_name("", "scan"),
             {false, 5, false}),
        joints(participant, sensor_msgs_msg_dds__JointState__desc,
               dds_topic_name("", "joint_states"), {true, 10, false}),
        cmd_vel(participant, geometry_msgs_msg_dds__Twist__desc, dds_topic_name("", "cmd_vel"),
                {true, 100, false}),
        head_command(participant, std_msgs_msg_dds__Float64MultiArray__desc,
                     dds_topic_name("", "pan_tilt_controller/commands"), {true, 10, false}),
        spec_(spec) {}

  void send_odometry(double t_s, double x_m, double v_mps = 0.0) {
    Odometry o;
    o.t_s = t_s;
    o.pose = {x_m, 0.5, 0.25};
    o.v_mps = v_mps;
    OdometryMessage m;
    fill_odometry(o, spec_, m);
    odom.write(m.msg);
  }
  // Odometry at 100 Hz from a thread until stopped: the base is alive.
  void start_odometry() {
    running = true;
    thread = std::thread([this] {
      double t = 0.0;
      while (running) {
        send_odometry(t, 1.0 + t);
        t += 0.01;
        std::this_thread::sleep_for(10ms);
      }
    });
  }
  void stop_odometry() {
    running = false;
    if (thread.joinable()) thread.join();
  }
  ~Peer() { stop_odometry(); }
  std::vector<geometry_msgs_msg_dds__Twist_> twists(std::chrono::milliseconds wait = 200ms) {
    std::this_thread::sleep_for(wait);
    std::vector<geometry_msgs_msg_dds__Twist_> out;
    cmd_vel.take(
        [&](const geometry_msgs_msg_dds__Twist_& t, const dds_sample_info_t&) { out.push_back(t); },
        1000);
    return out;
  }

  Participant participant;
  Writer<nav_msgs_msg_dds__Odometry_> odom;
  Writer<sensor_msgs_msg_dds__LaserScan_> scan;
  Writer<sensor_msgs_msg_dds__JointState_> joints;
  Reader<geometry_msgs_msg_dds__Twist_> cmd_vel;
  Reader<std_msgs_msg_dds__Float64MultiArray_> head_command;
  std::atomic<bool> running{false};
  std::thread thread;
  Ros2Spec spec_;
};

class Ros2Drivers : public ::testing::Test {
 protected:
  Ros2Drivers() {
    Ros2Spec& spec = rig.mission.robot.ros2;
    spec.domain_id = test::claim_dds_domain();
    spec.loopback_only = true;
    spec.odom_timeout_s = 0.3;
    rig.run.dry_run = false;  // hardware: no /clock, wall-time timeouts
    params.set("startup_timeout_s", ParamValue(3.0));
  }
  const Ros2Spec& spec() const { return rig.mission.robot.ros2; }
  static bool wait_until(const std::function<bool()>& done,
                         std::chrono::milliseconds limit = 3000ms) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(2ms);
    }
    return true;
  }

  test::RunRig rig{test::RunRig::RunDir::none};
  Params params;
};

TEST_F(Ros2Drivers, BaseReadsOdometryAndSendsClampedTwists) {
  Peer peer(spec());
  peer.start_odometry();
  Ros2Base base(params, rig.run);
  base.update(0.0);
  const Odometry o = base.odometry();
  EXPECT_NEAR(o.pose.x_m, 1.0 + o.t_s, 1e-9);
  EXPECT_DOUBLE_EQ(o.pose.y_m, 0.5);
  EXPECT_NEAR(o.pose.yaw_rad, 0.25, 1e-12);
  ASSERT_TRUE(wait_until([&] { return peer.cmd_vel.matched() > 0; }));
  base.command_velocity(0.2, -0.1);
  base.command_velocity(5.0, 0.0);  // the robot file's 0.5 m/s
  const auto sent = peer.twists();
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_DOUBLE_EQ(sent[0].linear.x, 0.2);
  EXPECT_DOUBLE_EQ(sent[0].angular.z, -0.1);
  EXPECT_DOUBLE_EQ(sent[1].linear.x, rig.mission.robot.base.max_speed_mps);
}

TEST_F(Ros2Drivers, SafeStopSendsRepeatedZeroTwists) {
  Peer peer(spec());
  peer.start_odometry();
  Ros2Base base(params, rig.run);
  ASSERT_TRUE(wait_until([&] { return peer.cmd_vel.matched() > 0; }));
  base.command_velocity(0.3, 0.0);
  base.safe_stop();
  const auto sent = peer.twists();
  ASSERT_EQ(sent.size(), 1u + static_cast<std::size_t>(spec().stop_repeats));
  for (std::size_t i = 1; i < sent.size(); ++i) {
    EXPECT_EQ(sent[i].linear.x, 0.0);
    EXPECT_EQ(sent[i].angular.z, 0.0);
  }
}

TEST_F(Ros2Drivers, NobodyPublishingIsAnErrorBeforeAnythingMoves) {
  params.set("startup_timeout_s", ParamValue(0.3));
  try {
    Ros2Base base(params, rig.run);
    FAIL() << "no error";
  } catch (const DriverError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no valid odometry on rt/odom within"));
    EXPECT_THAT(e.what(), HasSubstr("nobody publishes rt/odom on DDS domain " +
                                    std::to_string(spec().domain_id)));
  }
}

TEST_F(Ros2Drivers, ATopicOfTheWrongTypeIsNamedWithBothTypes) {
  Participant other({spec().domain_id, true}, "wrong_type");
  Writer<std_msgs_msg_dds__String_> wrong(other, std_msgs_msg_dds__String__desc, "rt/odom",
                                          {true, 10, false});
  std_msgs_msg_dds__String_ text{const_cast<char*>("not odometry")};
  wrong.write(text);
  params.set("startup_timeout_s", ParamValue(1.0));
  try {
    Ros2Base base(params, rig.run);
    FAIL() << "no error";
  } catch (const DriverError& e) {
    EXPECT_THAT(e.what(), HasSubstr("rt/odom is published as std_msgs::msg::dds_::String_, "
                                    "expected nav_msgs::msg::dds_::Odometry_"));
  }
}

TEST_F(Ros2Drivers, NaNOdometryIsRefusedAndSaidSo) {
  Peer peer(spec());
  std::atomic<bool> run{true};
  std::thread nan_sender([&] {
    while (run) {
      peer.send_odometry(0.0, std::nan(""));
      std::this_thread::sleep_for(5ms);
    }
  });
  params.set("startup_timeout_s", ParamValue(0.5));
  try {
    Ros2Base base(params, rig.run);
    ADD_FAILURE() << "no error";
  } catch (const DriverError& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("the last message was refused: pose.pose.position is not finite"));
  }
  run = false;
  nan_sender.join();
  EXPECT_THAT(rig.log.messages(LogLevel::warning),
              testing::Contains(HasSubstr("odometry refused on rt/odom")));
}

TEST_F(Ros2Drivers, OdometryThatStopsStopsTheRobotUntilItIsBack) {
  Peer peer(spec());
  peer.start_odometry();
  Ros2Base base(params, rig.run);
  ASSERT_TRUE(wait_until([&] { return peer.cmd_vel.matched() > 0; }));
  base.command_velocity(0.4, 0.0);
  peer.stop_odometry();  // the base's computer hangs, or its publisher vanishes
  std::this_thread::sleep_for(400ms);
  EXPECT_THROW(
      {
        try {
          base.update(1.0);
        } catch (const DriverError& e) {
          EXPECT_THAT(e.what(), HasSubstr("robot stopped: no valid odometry on rt/odom for"));
          throw;
        }
      },
      DriverError);
  // Every command meanwhile is refused with a stop, never passed on.
  EXPECT_THROW(base.command_velocity(0.4, 0.0), DriverError);
  const auto sent = peer.twists();
  ASSERT_GE(sent.size(), 1u + static_cast<std::size_t>(spec().stop_repeats));
  EXPECT_DOUBLE_EQ(sent.front().linear.x, 0.4);
  for (std::size_t i = 1; i < sent.size(); ++i) EXPECT_EQ(sent[i].linear.x, 0.0);
  peer.start_odometry();
  ASSERT_TRUE(wait_until([&] {
    try {
      base.update(2.0);
      return true;
    } catch (const DriverError&) {
      return false;
    }
  }));
  base.command_velocity(0.1, 0.0);
  const auto after = peer.twists();
  ASSERT_FALSE(after.empty());
  EXPECT_DOUBLE_EQ(after.back().linear.x, 0.1);
}

TEST_F(Ros2Drivers, APublisherThatVanishesIsTheSameAsSilence) {
  auto peer = std::make_unique<Peer>(spec());
  peer->start_odometry();
  Ros2Base base(params, rig.run);
  peer.reset();  // its participant leaves the domain
  std::this_thread::sleep_for(400ms);
  EXPECT_THROW(base.update(1.0), DriverError);
}

TEST_F(Ros2Drivers, NonFiniteCommandsStopTheRobot) {
  Peer peer(spec());
  peer.start_odometry();
  Ros2Base base(params, rig.run);
  ASSERT_TRUE(wait_until([&] { return peer.cmd_vel.matched() > 0; }));
  EXPECT_THROW(base.command_velocity(std::nan(""), 0.0), DriverError);
  const auto sent = peer.twists();
  ASSERT_EQ(sent.size(), static_cast<std::size_t>(spec().stop_repeats));
  for (const auto& t : sent) EXPECT_EQ(t.linear.x, 0.0);
}

TEST_F(Ros2Drivers, AFloodIsTakenInBoundedBatchesAndTheNewestWins) {
  Peer peer(spec());
  peer.start_odometry();
  Ros2Base base(params, rig.run);
  peer.stop_odometry();
  for (int i = 1; i <= 20000; ++i) peer.send_odometry(i * 1e-3, i);
  std::this_thread::sleep_for(100ms);
  const auto t0 = std::chrono::steady_clock::now();
  base.update(0.0);
  const double update_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Keep-last 10 on the reader: the flood's tail, never 20000 samples at once.
  EXPECT_LT(update_s, 0.05);
  EXPECT_DOUBLE_EQ(base.odometry().pose.x_m, 20000.0);
}

TEST_F(Ros2Drivers, LaserReadsTheNewestValidScanAndDropsRefusedOnes) {
  Peer peer(spec());
  Ros2Laser laser(params, rig.run);
  ASSERT_TRUE(wait_until([&] { return peer.scan.matched() > 0; }));
  LaserScan s;
  s.t_s = 2.0;
  s.angle_min_rad = -1.0;
  s.angle_increment_rad = 0.01;
  s.max_range_m = 20.0;
  s.ranges_m.assign(201, 4.0f);
  s.valid.assign(201, 1);
  s.valid[7] = 0;
  ScanMessage m;
  fill_scan(s, "laser", m);
  peer.scan.write(m.msg);
  m.msg.angle_increment = std::nanf("");
  peer.scan.write(m.msg);  // refused
  std::optional<LaserScan> got;
  ASSERT_TRUE(wait_until([&] { return (got = laser.take_scan()).has_value(); }));
  EXPECT_DOUBLE_EQ(got->t_s, 2.0);
  EXPECT_EQ(got->ranges_m.size(), 201u);
  EXPECT_EQ(got->valid[7], 0);
  EXPECT_EQ(got->valid[8], 1);
  EXPECT_TRUE(got->T_base_laser.isApprox(rig.mission.robot.laser.T_base_laser));
  std::this_thread::sleep_for(50ms);
  EXPECT_FALSE(laser.take_scan());
  EXPECT_THAT(rig.log.messages(LogLevel::warning),
              testing::Contains(HasSubstr("scan refused on rt/scan")));
}

TEST_F(Ros2Drivers, PanTiltCommandsPositionsAndReadsJointsByName) {
  Peer peer(spec());
  std::atomic<bool> run{true};
  std::thread states([&] {
    while (run) {
      JointStateMessage m;
      fill_joint_state(0.0, {0.1, 0.2}, spec(), m);
      peer.joints.write(m.msg);
      std::this_thread::sleep_for(10ms);
    }
  });
  {
    Ros2PanTilt head(params, rig.run);
    head.update(0.0);
    EXPECT_DOUBLE_EQ(head.measured().pan_rad, 0.1);
    EXPECT_DOUBLE_EQ(head.measured().tilt_rad, 0.2);
    ASSERT_TRUE(wait_until([&] { return peer.head_command.matched() > 0; }));
    head.command({0.5, -0.1});
    EXPECT_FALSE(head.reached());
    std::vector<double> received;
    ASSERT_TRUE(wait_until([&] {
      peer.head_command.take(
          [&](const std_msgs_msg_dds__Float64MultiArray_& c, const dds_sample_info_t&) {
            received.assign(c.data._buffer, c.data._buffer + c.data._length);
          });
      return !received.empty();
    }));
    EXPECT_EQ(received, (std::vector<double>{0.5, -0.1}));
  }
  run = false;
  states.join();
}

// Regression: the dry run's clock was the absolute /clock, so two simulated robots on one domain
// (namespaces /ud1 and /ud2) each stepped their bridge by both tours' ticks (docs/fleet.md).
TEST_F(Ros2Drivers, Regression_ADryRunsClockIsUnderTheRobotsNamespace) {
  rig.mission.robot.ros2.ros2_namespace = "/ud1";
  rig.run.dry_run = true;
  params.set("startup_timeout_s", ParamValue(0.2));
  try {
    Ros2Base base(params, rig.run);
    FAIL() << "no error without a bridge";
  } catch (const DriverError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no simulator (projtour-sim-ros2) reads rt/ud1/clock"));
  }
}

}  // namespace
}  // namespace projtour::ros2
