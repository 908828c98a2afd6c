#pragma once
// The live monitor: a run serves its own page and JSON over HTTP (cpp-httplib, on a thread of
// its own), and takes the operator's controls. The tick loop never waits on it: once per tick
// it publishes a snapshot under a lock (values and shared pointers, nothing rendered) and
// drains the control requests queued since; the server renders from the latest snapshot.
//
// API (all JSON unless said; read-only views need no token):
//   GET  /                         the page
//   GET  /api/state                the tour now: mission time, active state, the current visit's
//                                  trail, poses (true one in a dry run), plan, people, targets
//                                  with their status, the report's records, frame sequences
//   GET  /api/machine              the state machine: every state, its kind and transitions
//   GET  /api/map                  the map's size, resolution and origin; /api/map.png the map
//   GET  /api/events?since=N       events from index N on: {first, next, events}, `first` the
//                                  oldest index still kept (the last 20000), `next` the one after
//                                  the last; events[0] is index max(N, first)
//   GET  /api/frame/KIND.png       the latest depth, colour or projector frame (at most 2 Hz)
//   GET  /api/stream               Server-Sent Events: `state` (at most 2 Hz) and `events`
//   POST /api/control/REQUEST      pause, resume, cancel, skip, retry (?target=ID); needs
//                                  `Authorization: Bearer TOKEN`: 401 without, 429 beyond
//                                  the rate, 413 beyond the size
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/machine/machine.hpp"
#include "projtour/record/events.hpp"
#include "projtour/record/target_record.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}
namespace cv {
class Mat;
}

namespace projtour {

struct MissionSpec;

struct MonitorOptions {
  std::string host = "127.0.0.1";
  int port = 8470;  // 0: any free port (tests); port() tells which
  std::string token;
  // Per second, over every request / over control requests (a burst of twice as many).
  double requests_per_s = 50.0;
  double controls_per_s = 5.0;
};

// "[HOST:]PORT" as --monitor takes it. Throws std::invalid_argument saying what was expected.
MonitorOptions parse_monitor_address(const std::string& text);
bool is_loopback_host(const std::string& host);
// 128 random bits as 32 hex digits, from the system's random source.
std::string make_monitor_token();

struct MonitorTarget {
  std::string id;
  Pose2D pose;  // the model frame on the floor
};

// What the tick loop publishes once per tick: cheap to copy.
struct MonitorSnapshot {
  double mission_s = 0.0;
  std::string active_state;
  std::optional<std::string> target;
  bool paused = false;
  bool finished = false;
  std::string outcome;  // the tour's, once finished
  std::optional<Pose2D> estimate;
  std::optional<Pose2D> truth;  // dry run only
  std::shared_ptr<const std::vector<Pose2D>> plan;
  std::vector<Eigen::Vector2d> people;  // dry run only
  std::shared_ptr<const std::vector<TargetRecord>> records;
};

// A control request as the tick loop receives it.
struct MonitorControl {
  std::string request;
  std::string target;  // retry's
};
struct MonitorReply {
  bool accepted = false;
  std::string message;
};

class MonitorServer : public ExecutorObserver {
 public:
  struct Fixed {  // what does not change during the run
    std::string mission;
    bool dry_run = false;
    const Machine* machine = nullptr;
    std::shared_ptr<const mrpt::maps::COccupancyGridMap2D> map;
    std::vector<MonitorTarget> targets;
  };
  // Binds and starts serving; throws std::runtime_error when the address cannot be bound.
  MonitorServer(MonitorOptions options, Fixed fixed);
  ~MonitorServer() override;
  MonitorServer(const MonitorServer&) = delete;
  MonitorServer& operator=(const MonitorServer&) = delete;

  int port() const;

  // The tick loop's side.
  void publish(MonitorSnapshot snapshot);
  // A frame for the page, kept at most twice a second of wall time (the rest are dropped
  // before any copy). `kind`: depth (16-bit mm), colour or projector (8-bit BGR).
  bool wants_frame(const std::string& kind) const;
  void publish_frame(const std::string& kind, const cv::Mat& image);
  // Calls `handle` for each control request queued since the last call; its reply goes back
  // to the waiting HTTP request.
  void drain_controls(const std::function<MonitorReply(const MonitorControl&)>& handle);
  // The run is over: the stream says so and no control is taken any more.
  void close();

  void on_event(const ExecutorEvent& event) override;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace projtour
