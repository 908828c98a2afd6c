// The demo tour with its base and laser over ROS 2: projtour's ros2_base and ros2_laser on
// loopback DDS against projtour-sim-ros2, beside the same tour on the simulated drivers
// directly. Same tour, same figures within noise; and the status on DDS says what happened.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "projtour/formats/json_io.hpp"
#include "projtour/ros2/dds.hpp"
#include "projtour/ros2/messages.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/run_files.hpp"
#include "projtour_test/temp_dir.hpp"
#include "ros2_test_domain.hpp"

namespace projtour::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using ros2::Participant;
using ros2::Reader;

const std::string kMission = PROJTOUR_SOURCE_DIR "/missions/demo_tour.yaml";
const std::string kWorld = PROJTOUR_SOURCE_DIR "/missions/demo_world.yaml";

ChildOptions bridge_command(const fs::path& dir) {
  ChildOptions o;
  o.argv = {PROJTOUR_BINARY_DIR "/projtour-sim-ros2",
            kMission,
            "--world",
            kWorld,
            "--seed",
            "1",
            "--idle-exit-s",
            "10"};
  o.stdout_file = dir / "bridge.stdout";
  o.stderr_file = dir / "bridge.stderr";
  return o;
}

// The status topics, heard from outside as a dashboard would.
struct StatusListener {
  explicit StatusListener(int domain)
      : participant({domain, true}, "dashboard"),
        state(participant, std_msgs_msg_dds__String__desc, "rt/projtour/state", {true, 1, true}),
        results(participant, std_msgs_msg_dds__String__desc, "rt/projtour/results",
                {true, 100, true}),
        pose(participant, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
             "rt/projtour/pose", {true, 10, true}) {
    thread = std::thread([this] {
      while (running) {
        state.take([&](const std_msgs_msg_dds__String_& s, const dds_sample_info_t&) {
          if (states.empty() || states.back() != s.data) states.emplace_back(s.data);
        });
        results.take([&](const std_msgs_msg_dds__String_& s, const dds_sample_info_t&) {
          records.push_back(parse_json(s.data, "projtour/results"));
        });
        pose.take([&](const geometry_msgs_msg_dds__PoseWithCovarianceStamped_&,
                      const dds_sample_info_t&) { ++poses; });
        std::this_thread::sleep_for(1ms);
      }
    });
  }
  ~StatusListener() { stop(); }
  void stop() {
    running = false;
    if (thread.joinable()) thread.join();
  }
  Participant participant;
  Reader<std_msgs_msg_dds__String_> state;
  Reader<std_msgs_msg_dds__String_> results;
  Reader<geometry_msgs_msg_dds__PoseWithCovarianceStamped_> pose;
  std::vector<std::string> states;
  std::vector<Json> records;
  int poses = 0;
  std::atomic<bool> running{true};
  std::thread thread;
};

TEST(Ros2Tour, DemoTourOverDdsMatchesTheDirectDryRunAndPublishesItsStatus) {
  const int domain = claim_dds_domain();
  TempDir dir("ros2-tour");
  Child bridge(bridge_command(dir.path()));
  StatusListener status(domain);
  // ros2_base and ros2_laser make this a ROS 2 robot: its status goes out on DDS too.
  const RunResult over_dds = run_projtour({"run", kMission, "--dry-run", "--ros2-bridge", "--world",
                                           kWorld, "--seed", "1", "--out", (dir / "dds").string()},
                                          dir / "dds", 400s);
  status.stop();
  ASSERT_EQ(over_dds.status, 0) << over_dds.err << read_text(bridge.stderr_file());
  const RunResult direct = run_projtour({"run", kMission, "--dry-run", "--world", kWorld, "--seed",
                                         "1", "--out", (dir / "direct").string()},
                                        dir / "direct", 400s);
  ASSERT_EQ(direct.status, 0) << direct.err;

  const Json a = read_json(dir / "dds" / "report.json");
  const Json b = read_json(dir / "direct" / "report.json");
  ASSERT_EQ(a["targets"].size(), b["targets"].size());
  for (std::size_t i = 0; i < a["targets"].size(); ++i) {
    const Json& ta = a["targets"][i];
    const Json& tb = b["targets"][i];
    SCOPED_TRACE(ta["id"].get<std::string>());
    EXPECT_EQ(ta["outcome"], "projected");
    EXPECT_EQ(ta["outcome"], tb["outcome"]);
    // Within noise: the scans and the odometry are the same world's, a tick later at most.
    EXPECT_LT(ta["projection_error_mm"]["after_align"].get<double>(), 3.0);
    EXPECT_NEAR(ta["projection_error_mm"]["after_align"].get<double>(),
                tb["projection_error_mm"]["after_align"].get<double>(), 2.5);
  }
  const double t_dds = a["timing"]["mission_s"].get<double>();
  const double t_direct = b["timing"]["mission_s"].get<double>();
  EXPECT_NEAR(t_dds, t_direct, 0.05 * t_direct);

  // The bridge stepped once per tick and stopped when the tour's clock did.
  EXPECT_EQ(bridge.wait(30s), 0) << read_text(bridge.stderr_file());
  EXPECT_THAT(read_text(bridge.stderr_file()), testing::HasSubstr("stopped after"));

  // The status: every visit's record, the states passed through, the pose as it went.
  ASSERT_EQ(status.records.size(), a["targets"].size());
  for (std::size_t i = 0; i < status.records.size(); ++i) {
    EXPECT_EQ(status.records[i]["id"], a["targets"][i]["id"]);
    EXPECT_EQ(status.records[i]["outcome"], a["targets"][i]["outcome"]);
  }
  ASSERT_FALSE(status.states.empty());
  EXPECT_EQ(status.states.back(), "finished:completed");
  EXPECT_THAT(status.states, testing::Contains(testing::HasSubstr("/align")));
  EXPECT_GT(status.poses, 100);
}

TEST(Ros2Tour, WithoutTheBridgeNothingMovesAndTheErrorSaysWhatToStart) {
  claim_dds_domain();
  TempDir dir("ros2-no-bridge");
  const RunResult r = run_projtour({"run", kMission, "--dry-run", "--ros2-bridge", "--world",
                                    kWorld, "--seed", "1", "--out", (dir / "run").string()},
                                   dir / "run", 120s);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, testing::HasSubstr("no simulator (projtour-sim-ros2) reads rt/clock"));
}

TEST(Ros2Tour, TheBridgeIsOnlyForADryRun) {
  const RunResult r = run_projtour({"validate", kMission, "--ros2-bridge"}, {}, 60s);
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, testing::HasSubstr("--ros2-bridge is only for a dry run (add --dry-run)"));
}

}  // namespace
}  // namespace projtour::test
