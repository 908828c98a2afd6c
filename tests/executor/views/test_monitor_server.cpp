// The live monitor's server over real HTTP (issue 16): what a script or a browser gets, and
// what it may not do. The tick loop's side is played by the test: publish, drain the controls.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "projtour/formats/json_io.hpp"
#include "projtour/views/monitor.hpp"
// After Eigen (monitor.hpp): httplib includes <resolv.h>, whose `_res` macro is a parameter name
// in Eigen's headers.
#include <httplib.h>

namespace projtour {
namespace {

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

class MonitorServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    MonitorOptions options;
    options.port = 0;
    options.token = kToken;
    MonitorServer::Fixed fixed;
    fixed.mission = "test-mission";
    fixed.targets = {{"rabbit", {1.0, 2.0, 0.0}}, {"sign", {3.0, 4.0, 0.0}}};
    server_ = std::make_unique<MonitorServer>(options, std::move(fixed));
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    // The tick loop: answers every control by echoing it.
    ticking_ = std::thread([this] {
      while (!stop_) {
        server_->drain_controls([this](const MonitorControl& c) {
          ++controls_taken_;
          return MonitorReply{true, c.request + (c.target.empty() ? "" : " " + c.target)};
        });
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
  }
  void TearDown() override {
    stop_ = true;
    ticking_.join();
  }
  httplib::Result post(const std::string& path, const std::string& token,
                       const std::string& body = "") {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    return client_->Post(path.c_str(), headers, body, "application/json");
  }

  std::unique_ptr<MonitorServer> server_;
  std::unique_ptr<httplib::Client> client_;
  std::thread ticking_;
  std::atomic<bool> stop_{false};
  std::atomic<int> controls_taken_{0};
};

TEST_F(MonitorServerTest, StateIsTheLatestSnapshotAsJson) {
  MonitorSnapshot s;
  s.mission_s = 12.5;
  s.active_state = "tour/visit/align";
  s.target = "rabbit";
  s.estimate = Pose2D{1.0, 1.5, 0.25};
  server_->publish(s);
  const auto res = client_->Get("/api/state");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  const Json j = parse_json(res->body, "/api/state");
  EXPECT_EQ(j.at("mission"), "test-mission");
  EXPECT_EQ(j.at("mission_s"), 12.5);
  EXPECT_EQ(j.at("active_state"), "tour/visit/align");
  EXPECT_EQ(j.at("estimate").at("y"), 1.5);
  EXPECT_TRUE(j.at("truth").is_null());
  EXPECT_EQ(j.at("targets").at(0).at("status"), "visiting");
  EXPECT_EQ(j.at("targets").at(1).at("status"), "pending");
}

TEST_F(MonitorServerTest, ControlWithoutTheTokenIs401AndReachesNothing) {
  for (const std::string& token :
       {std::string(), std::string("wrong"), std::string(kToken).substr(1) + "0"}) {
    const auto res = post("/api/control/pause", token);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 401) << token;
  }
  EXPECT_EQ(controls_taken_, 0);
  const auto res = post("/api/control/retry?target=sign", kToken);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(parse_json(res->body, "reply").at("message"), "retry sign");
  EXPECT_EQ(controls_taken_, 1);
}

TEST_F(MonitorServerTest, UnknownControlsBadParametersAndLargeBodiesAreRefused) {
  EXPECT_EQ(post("/api/control/explode", kToken)->status, 404);
  EXPECT_EQ(post("/api/control/retry", kToken)->status, 400);
  EXPECT_EQ(post("/api/control/pause", kToken, std::string(100000, 'x'))->status, 413);
  EXPECT_EQ(client_->Get("/api/events?since=-1")->status, 400);
  EXPECT_EQ(client_->Get("/api/events?since=x")->status, 400);
  EXPECT_EQ(client_->Get("/api/map")->status, 404);  // this run has no map
  EXPECT_EQ(controls_taken_, 0);
}

TEST_F(MonitorServerTest, ControlsBeyondTheRateAre429) {
  int ok = 0;
  int limited = 0;
  for (int i = 0; i < 30; ++i) {
    const int status = post("/api/control/pause", kToken)->status;
    ok += status == 200;
    limited += status == 429;
  }
  // A burst of ten at five a second: the rest of thirty in quick succession are refused.
  EXPECT_GE(ok, 10);
  EXPECT_LE(ok, 15);
  EXPECT_EQ(ok + limited, 30);
}

TEST_F(MonitorServerTest, EventsSinceAnIndexAndTheOldestKept) {
  for (int i = 0; i < 20005; ++i) {
    ExecutorEvent e;
    e.t_s = i;
    e.state = "tour";
    server_->on_event(e);
  }
  const Json j = parse_json(client_->Get("/api/events?since=20000")->body, "events");
  EXPECT_EQ(j.at("first"), 5);
  EXPECT_EQ(j.at("next"), 20005);
  ASSERT_EQ(j.at("events").size(), 5u);
  EXPECT_EQ(j.at("events").at(0).at("t"), 20000);
  // From before the oldest kept: from the oldest.
  EXPECT_EQ(parse_json(client_->Get("/api/events?since=0")->body, "events").at("events").size(),
            20000u);
}

TEST_F(MonitorServerTest, TheStreamSendsStateAndEndsWhenTheRunIsOver) {
  std::string received;
  std::thread reader([&] {
    client_->Get("/api/stream", [&](const char* data, std::size_t n) {
      received.append(data, n);
      return true;
    });
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  MonitorSnapshot s;
  s.mission_s = 1.0;
  server_->publish(s);
  ExecutorEvent e;
  e.state = "tour";
  server_->on_event(e);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  s.finished = true;
  s.outcome = "completed";
  server_->publish(s);
  server_->close();
  reader.join();
  EXPECT_NE(received.find("event: state\ndata: "), std::string::npos) << received;
  EXPECT_NE(received.find("event: events\ndata: "), std::string::npos) << received;
  EXPECT_NE(received.find("\"outcome\": \"completed\""), std::string::npos) << received;
  EXPECT_NE(received.find("event: end\n"), std::string::npos) << received;
  // After the end, controls are refused: the run is over.
  EXPECT_EQ(post("/api/control/pause", kToken)->status, 409);
}

TEST(MonitorAddress, PortsHostsAndTheirErrors) {
  EXPECT_EQ(parse_monitor_address("8470").port, 8470);
  EXPECT_EQ(parse_monitor_address("8470").host, "127.0.0.1");
  EXPECT_EQ(parse_monitor_address("0.0.0.0:0").host, "0.0.0.0");
  EXPECT_EQ(parse_monitor_address("[::1]:9000").host, "::1");
  EXPECT_THROW(parse_monitor_address("70000"), std::invalid_argument);
  EXPECT_THROW(parse_monitor_address("host:"), std::invalid_argument);
  EXPECT_THROW(parse_monitor_address(":80"), std::invalid_argument);
  EXPECT_TRUE(is_loopback_host("127.0.0.1"));
  EXPECT_TRUE(is_loopback_host("::1"));
  EXPECT_FALSE(is_loopback_host("0.0.0.0"));
  EXPECT_EQ(make_monitor_token().size(), 32u);
  EXPECT_NE(make_monitor_token(), make_monitor_token());
}

}  // namespace
}  // namespace projtour
