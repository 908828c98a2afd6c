// ROS 2 messages to and from projtour's driver types, and what is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "projtour/ros2/messages.hpp"

namespace projtour::ros2 {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

TEST(Ros2Time, SplitsIntoSecondsAndNanoseconds) {
  const auto t = to_time(12.25);
  EXPECT_EQ(t.sec, 12);
  EXPECT_EQ(t.nanosec, 250000000u);
  EXPECT_DOUBLE_EQ(from_time(t), 12.25);
  // Rounding up to a whole second never writes nanosec = 1e9 (out of ROS 2's range).
  EXPECT_LT(to_time(3.9999999999).nanosec, 1000000000u);
}

struct OdomFixture : ::testing::Test {
  Ros2Spec spec;
  OdometryMessage out;
  void SetUp() override {
    Odometry o;
    o.t_s = 4.5;
    o.pose = {1.5, -2.0, 2.5};
    o.v_mps = 0.3;
    o.w_radps = -0.2;
    fill_odometry(o, spec, out);
  }
};

TEST_F(OdomFixture, RoundTripsPoseTwistStampAndFrames) {
  const OdometryRead r = read_odometry(out.msg, spec);
  ASSERT_TRUE(r.odometry) << r.refusal.reason;
  EXPECT_DOUBLE_EQ(r.odometry->t_s, 4.5);
  EXPECT_DOUBLE_EQ(r.odometry->pose.x_m, 1.5);
  EXPECT_DOUBLE_EQ(r.odometry->pose.y_m, -2.0);
  EXPECT_NEAR(r.odometry->pose.yaw_rad, 2.5, 1e-12);
  EXPECT_DOUBLE_EQ(r.odometry->v_mps, 0.3);
  EXPECT_DOUBLE_EQ(r.odometry->w_radps, -0.2);
  EXPECT_STREQ(out.msg.header.frame_id, "odom");
  EXPECT_STREQ(out.msg.child_frame_id, "base_link");
}

TEST_F(OdomFixture, RefusesNaNAndBrokenQuaternionsAndOtherFrames) {
  auto refused = [&](auto change) {
    nav_msgs_msg_dds__Odometry_ m = out.msg;
    change(m);
    const OdometryRead r = read_odometry(m, spec);
    EXPECT_FALSE(r.odometry);
    return r.refusal.reason;
  };
  EXPECT_EQ(refused([](auto& m) { m.pose.pose.position.x = std::nan(""); }),
            "pose.pose.position is not finite");
  EXPECT_EQ(refused([](auto& m) { m.twist.twist.angular.z = INFINITY; }),
            "twist.twist is not finite");
  EXPECT_EQ(refused([](auto& m) {
              m.pose.pose.orientation.w = 0.0;
            }).rfind("pose.pose.orientation is not a unit quaternion", 0),
            0u);
  EXPECT_EQ(refused([](auto& m) {
              m.pose.pose.orientation = {std::sqrt(0.5), 0.0, 0.0, std::sqrt(0.5)};
            }),
            "pose.pose.orientation is tilted off the floor");
  EXPECT_EQ(refused([](auto& m) { m.header.frame_id = const_cast<char*>("map"); }),
            "header.frame_id is \"map\", expected \"odom\"");
  EXPECT_EQ(refused([](auto& m) { m.child_frame_id = const_cast<char*>("base_footprint"); }),
            "child_frame_id is \"base_footprint\", expected \"base_link\"");
  EXPECT_EQ(refused([](auto& m) { m.header.stamp.nanosec = 1000000000u; }),
            "header.stamp.nanosec 1000000000 is not below 1e9");
  // tf2's old leading slash names the same frame.
  nav_msgs_msg_dds__Odometry_ m = out.msg;
  m.header.frame_id = const_cast<char*>("/odom");
  EXPECT_TRUE(read_odometry(m, spec).odometry);
}

sensor_msgs_msg_dds__LaserScan_ scan_of(std::vector<float>& ranges, float angle_min,
                                        float increment) {
  sensor_msgs_msg_dds__LaserScan_ m{};
  m.header.stamp = to_time(7.1);
  m.header.frame_id = const_cast<char*>("laser");
  m.angle_min = angle_min;
  m.angle_increment = increment;
  m.angle_max = angle_min + increment * static_cast<float>(ranges.size() - 1);
  m.range_min = 0.1f;
  m.range_max = 30.0f;
  m.ranges._buffer = ranges.data();
  m.ranges._length = m.ranges._maximum = static_cast<uint32_t>(ranges.size());
  return m;
}

TEST(Ros2Scan, ValidReadingsAreFiniteAndWithinTheRange) {
  Ros2Spec spec;
  std::vector<float> ranges = {1.0f, kInf, kNaN, 0.05f, 31.0f, 2.5f};
  const auto m = scan_of(ranges, -0.5f, 0.2f);
  const Eigen::Isometry3d T_base_laser(Eigen::Translation3d(0.2, 0, 0.3));
  const ScanRead r = read_scan(m, spec, T_base_laser);
  ASSERT_TRUE(r.scan) << r.refusal.reason;
  EXPECT_NEAR(r.scan->t_s, 7.1, 1e-9);
  EXPECT_NEAR(r.scan->angle_min_rad, -0.5, 1e-7);
  EXPECT_NEAR(r.scan->angle_increment_rad, 0.2, 1e-7);
  EXPECT_FLOAT_EQ(static_cast<float>(r.scan->max_range_m), 30.0f);
  EXPECT_EQ(r.scan->valid, (std::vector<char>{1, 0, 0, 0, 0, 1}));
  EXPECT_FLOAT_EQ(r.scan->ranges_m[5], 2.5f);
  EXPECT_TRUE(r.scan->T_base_laser.isApprox(T_base_laser));
}

TEST(Ros2Scan, ANegativeIncrementIsReversedToAscendingAngles) {
  Ros2Spec spec;
  std::vector<float> ranges = {1.0f, 2.0f, 3.0f};
  const auto m = scan_of(ranges, 0.4f, -0.2f);  // 0.4, 0.2, 0.0
  const ScanRead r = read_scan(m, spec, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(r.scan);
  EXPECT_NEAR(r.scan->angle_min_rad, 0.0, 1e-7);
  EXPECT_NEAR(r.scan->angle_increment_rad, 0.2, 1e-7);
  EXPECT_EQ(r.scan->ranges_m, (std::vector<float>{3.0f, 2.0f, 1.0f}));
}

TEST(Ros2Scan, RefusesWhatNoScannerSends) {
  Ros2Spec spec;
  std::vector<float> ranges = {1.0f, 2.0f};
  auto refused = [&](auto change) {
    auto m = scan_of(ranges, 0.0f, 0.1f);
    change(m);
    const ScanRead r = read_scan(m, spec, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(r.scan);
    return r.refusal.reason;
  };
  EXPECT_EQ(refused([](auto& m) { m.angle_increment = kNaN; }),
            "angle_min, angle_max, angle_increment, range_min or range_max is not finite");
  EXPECT_EQ(refused([](auto& m) { m.angle_increment = 0.0f; }), "angle_increment is 0");
  EXPECT_EQ(refused([](auto& m) { m.range_max = 0.0f; }).find("are no range"),
            std::string("range_min 0.100000 and range_max 0.000000 ").size());
  EXPECT_EQ(refused([](auto& m) { m.ranges._length = 0; }), "ranges is empty");
  EXPECT_EQ(refused([](auto& m) { m.angle_increment = 7.0f; }),
            "the readings span more than a full turn");
  spec.laser_frame = "laser_front";
  EXPECT_EQ(refused([](auto&) {}), "header.frame_id is \"laser\", expected \"laser_front\"");
}

TEST(Ros2Scan, NoReturnIsWrittenAsInfinity) {
  LaserScan s;
  s.t_s = 1.0;
  s.angle_min_rad = -1.0;
  s.angle_increment_rad = 0.5;
  s.max_range_m = 20.0;
  s.ranges_m = {1.0f, 0.0f, 3.0f};
  s.valid = {1, 0, 1};
  ScanMessage out;
  fill_scan(s, "laser", out);
  EXPECT_EQ(out.msg.ranges._length, 3u);
  EXPECT_TRUE(std::isinf(out.msg.ranges._buffer[1]));
  EXPECT_FLOAT_EQ(out.msg.angle_max, 0.0f);
  Ros2Spec spec;
  const ScanRead back = read_scan(out.msg, spec, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(back.scan);
  EXPECT_EQ(back.scan->valid, s.valid);
  EXPECT_EQ(back.scan->ranges_m[2], 3.0f);
}

TEST(Ros2Joints, ReadsByNameAmongOtherJoints) {
  Ros2Spec spec;
  char wheel[] = "left_wheel", tilt[] = "tilt_joint", pan[] = "pan_joint";
  char* names[] = {wheel, tilt, pan};
  double positions[] = {12.0, 0.3, -0.7};
  sensor_msgs_msg_dds__JointState_ m{};
  m.name._buffer = names;
  m.name._length = 3;
  m.position._buffer = positions;
  m.position._length = 3;
  JointsRead r = read_joints(m, spec);
  ASSERT_TRUE(r.angles);
  EXPECT_DOUBLE_EQ(r.angles->pan_rad, -0.7);
  EXPECT_DOUBLE_EQ(r.angles->tilt_rad, 0.3);
  positions[2] = std::nan("");
  r = read_joints(m, spec);
  EXPECT_FALSE(r.angles);
  EXPECT_EQ(r.refusal.reason, "position of joint \"pan_joint\" is not finite");
  m.position._length = 2;
  r = read_joints(m, spec);
  EXPECT_EQ(r.refusal.reason, "joint \"pan_joint\" has no position");
}

TEST(Ros2Pose, CovarianceGoesToXYAndYaw) {
  PoseEstimate2D e;
  e.mean = {1.0, 2.0, 0.5};
  e.t_s = 3.0;
  e.covariance << 0.01, 0.002, 0.0, 0.002, 0.02, 0.001, 0.0, 0.001, 0.03;
  PoseMessage out;
  fill_pose(e, out);
  EXPECT_DOUBLE_EQ(out.msg.pose.covariance[0], 0.01);
  EXPECT_DOUBLE_EQ(out.msg.pose.covariance[7], 0.02);
  EXPECT_DOUBLE_EQ(out.msg.pose.covariance[35], 0.03);
  EXPECT_DOUBLE_EQ(out.msg.pose.covariance[11], 0.001);
  const PoseEstimate2D back = read_pose(out.msg);
  EXPECT_NEAR(back.mean.yaw_rad, 0.5, 1e-12);
  EXPECT_TRUE(back.covariance.isApprox(e.covariance));
  EXPECT_STREQ(out.msg.header.frame_id, "map");
}

TEST(Ros2Names, RelativeNamesGoUnderTheNamespace) {
  EXPECT_EQ(dds_topic_name("", "cmd_vel"), "rt/cmd_vel");
  EXPECT_EQ(dds_topic_name("/ud1", "cmd_vel"), "rt/ud1/cmd_vel");
  EXPECT_EQ(dds_topic_name("/ud1", "/clock"), "rt/clock");
}

}  // namespace
}  // namespace projtour::ros2
