#include "projtour/views/monitor.hpp"

#include <httplib.h>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <thread>

#include "projtour/formats/json_io.hpp"
#include "projtour/views/monitor_page.hpp"

namespace projtour {
namespace {

using SteadyClock = std::chrono::steady_clock;

// The events kept for /api/events: a day's tour writes a few thousand an hour, and the page
// only ever shows the latest; the file has them all.
constexpr std::size_t kEventsKept = 20000;
constexpr auto kFramePeriod = std::chrono::milliseconds(500);  // frames at most 2 Hz
constexpr auto kStatePeriod = std::chrono::milliseconds(500);  // the stream's state, 2 Hz
constexpr auto kControlWait = std::chrono::seconds(3);         // for the tick loop's reply
constexpr int kFrameWidthPx = 320;
constexpr std::size_t kMaxRequestBytes = 4096;

Json pose_json(const Pose2D& p) {
  return Json{{"x", p.x_m}, {"y", p.y_m}, {"theta", p.yaw_rad}};
}

// A token bucket: `rate` per second, bursts of twice as many.
class RateLimit {
 public:
  explicit RateLimit(double rate) : rate_(rate), tokens_(2 * rate) {}
  bool take() {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = SteadyClock::now();
    tokens_ =
        std::min(2 * rate_, tokens_ + rate_ * std::chrono::duration<double>(now - last_).count());
    last_ = now;
    if (tokens_ < 1.0) return false;
    tokens_ -= 1.0;
    return true;
  }

 private:
  std::mutex mutex_;
  double rate_;
  double tokens_;
  SteadyClock::time_point last_ = SteadyClock::now();
};

struct Frame {
  cv::Mat small;  // 8-bit BGR, at most kFrameWidthPx wide
  std::uint64_t sequence = 0;
  std::string png;  // encoded on first request
  SteadyClock::time_point taken{};
};

struct PendingControl {
  MonitorControl control;
  std::promise<MonitorReply> reply;
};

}  // namespace

struct MonitorServer::Impl {
  MonitorOptions options;
  Fixed fixed;
  httplib::Server server;
  std::thread thread;
  int port = 0;
  RateLimit requests;
  RateLimit controls;
  std::string map_png;
  Json map_meta;
  Json machine_json;

  mutable std::mutex mutex;
  std::condition_variable changed;
  MonitorSnapshot snapshot;
  std::uint64_t snapshot_version = 0;
  std::vector<std::string> trail;  // leaves entered in the current visit
  std::deque<Json> events;
  std::size_t events_first = 0;  // index of events.front()
  std::map<std::string, Frame> frames;
  std::deque<std::shared_ptr<PendingControl>> pending;
  bool closed = false;
  int open_streams = 0;
  std::atomic<bool> stopping{false};

  Impl(MonitorOptions o, Fixed f)
      : options(std::move(o)),
        fixed(std::move(f)),
        requests(options.requests_per_s),
        controls(options.controls_per_s) {}

  std::size_t events_next() const { return events_first + events.size(); }

  Json targets_json(const MonitorSnapshot& s) const {
    Json out = Json::array();
    for (const MonitorTarget& t : fixed.targets) {
      std::string status = "pending";
      std::string reason;
      if (s.records) {
        for (const TargetRecord& r : *s.records) {
          if (r.id == t.id) {
            status = r.outcome;
            reason = r.reason;
          }
        }
      }
      if (s.target && *s.target == t.id && !s.finished) status = "visiting";
      out.push_back({{"id", t.id},
                     {"x", t.pose.x_m},
                     {"y", t.pose.y_m},
                     {"theta", t.pose.yaw_rad},
                     {"status", status},
                     {"reason", reason}});
    }
    return out;
  }

  // Under `mutex`.
  Json state_json() const {
    const MonitorSnapshot& s = snapshot;
    Json j;
    j["mission"] = fixed.mission;
    j["dry_run"] = fixed.dry_run;
    j["mission_s"] = s.mission_s;
    j["paused"] = s.paused;
    j["finished"] = s.finished;
    j["outcome"] = s.outcome;
    j["active_state"] = s.active_state;
    j["target"] = s.target ? Json(*s.target) : Json();
    j["trail"] = trail;
    j["estimate"] = s.estimate ? pose_json(*s.estimate) : Json();
    j["truth"] = s.truth ? pose_json(*s.truth) : Json();
    Json plan = Json::array();
    if (s.plan) {
      for (const Pose2D& p : *s.plan) plan.push_back(Json::array({p.x_m, p.y_m}));
    }
    j["plan"] = std::move(plan);
    Json people = Json::array();
    for (const Eigen::Vector2d& p : s.people) people.push_back(Json::array({p.x(), p.y()}));
    j["people"] = std::move(people);
    j["targets"] = targets_json(s);
    j["records"] = s.records ? Json(*s.records) : Json::array();
    Json frame_seq = Json::object();
    for (const char* kind : {"depth", "colour", "projector"}) {
      const auto it = frames.find(kind);
      frame_seq[kind] = it != frames.end() ? Json(it->second.sequence) : Json();
    }
    j["frames"] = std::move(frame_seq);
    j["events"] = events_next();
    return j;
  }

  // Under `mutex`.
  Json events_json(std::size_t since) const {
    const std::size_t from = std::max(since, events_first);
    Json list = Json::array();
    for (std::size_t i = from; i < events_next(); ++i) list.push_back(events[i - events_first]);
    return Json{{"first", events_first}, {"next", events_next()}, {"events", std::move(list)}};
  }

  bool authorised(const httplib::Request& req) const {
    const std::string header = req.get_header_value("Authorization");
    const std::string expected = "Bearer " + options.token;
    // Compared in full whatever the first difference, so timing says nothing of the token.
    if (header.size() != expected.size() || options.token.empty()) return false;
    unsigned char diff = 0;
    for (std::size_t i = 0; i < header.size(); ++i) {
      diff |= static_cast<unsigned char>(header[i] ^ expected[i]);
    }
    return diff == 0;
  }

  static void json_reply(httplib::Response& res, int status, const Json& body) {
    res.status = status;
    res.set_header("Cache-Control", "no-store");
    res.set_content(dump_json(body), "application/json");
  }

  void routes() {
    server.set_payload_max_length(kMaxRequestBytes);
    server.set_read_timeout(5, 0);
    server.set_write_timeout(5, 0);
    server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      if (req.body.size() > kMaxRequestBytes || req.target.size() > kMaxRequestBytes) {
        json_reply(res, 413, {{"error", "request too large"}});
        return httplib::Server::HandlerResponse::Handled;
      }
      if (!requests.take()) {
        json_reply(res, 429, {{"error", "too many requests"}});
        return httplib::Server::HandlerResponse::Handled;
      }
      return httplib::Server::HandlerResponse::Unhandled;
    });
    server.Get("/", [](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-store");
      res.set_content(monitor_page_html(), "text/html; charset=utf-8");
    });
    server.Get("/api/state", [this](const httplib::Request&, httplib::Response& res) {
      std::lock_guard<std::mutex> lock(mutex);
      json_reply(res, 200, state_json());
    });
    server.Get("/api/machine", [this](const httplib::Request&, httplib::Response& res) {
      json_reply(res, 200, machine_json);
    });
    server.Get("/api/map", [this](const httplib::Request&, httplib::Response& res) {
      if (map_meta.is_null()) return json_reply(res, 404, {{"error", "this run has no map"}});
      json_reply(res, 200, map_meta);
    });
    server.Get("/api/map.png", [this](const httplib::Request&, httplib::Response& res) {
      if (map_png.empty()) return json_reply(res, 404, {{"error", "this run has no map"}});
      res.set_content(map_png, "image/png");
    });
    server.Get("/api/events", [this](const httplib::Request& req, httplib::Response& res) {
      std::size_t since = 0;
      if (req.has_param("since")) {
        const std::string text = req.get_param_value("since");
        char* end = nullptr;
        const unsigned long long n = std::strtoull(text.c_str(), &end, 10);
        if (text.empty() || *end != '\0' || text[0] == '-') {
          return json_reply(res, 400, {{"error", "since: expected a non-negative integer"}});
        }
        since = static_cast<std::size_t>(n);
      }
      std::lock_guard<std::mutex> lock(mutex);
      json_reply(res, 200, events_json(since));
    });
    server.Get(R"(/api/frame/(depth|colour|projector)\.png)",
               [this](const httplib::Request& req, httplib::Response& res) {
                 std::lock_guard<std::mutex> lock(mutex);
                 const auto it = frames.find(req.matches[1].str());
                 if (it == frames.end()) {
                   return json_reply(res, 404, {{"error", "no such frame yet"}});
                 }
                 Frame& f = it->second;
                 if (f.png.empty()) {
                   std::vector<unsigned char> bytes;
                   cv::imencode(".png", f.small, bytes);
                   f.png.assign(bytes.begin(), bytes.end());
                 }
                 res.set_header("Cache-Control", "no-store");
                 res.set_content(f.png, "image/png");
               });
    server.Get("/api/stream",
               [this](const httplib::Request&, httplib::Response& res) { stream(res); });
    server.Post(R"(/api/control/([a-z]+))",
                [this](const httplib::Request& req, httplib::Response& res) { control(req, res); });
  }

  // Server-sent events: the state at most every kStatePeriod, the new events, and an end.
  void stream(httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++open_streams;
    }
    auto sent_version = std::make_shared<std::uint64_t>(~std::uint64_t{0});
    auto sent_events = std::make_shared<std::size_t>(0);
    auto last_state = std::make_shared<SteadyClock::time_point>();
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, sent_version, sent_events, last_state](std::size_t, httplib::DataSink& sink) {
          std::string out;
          bool ended = false;
          bool idle = false;
          {
            std::unique_lock<std::mutex> lock(mutex);
            idle = !changed.wait_for(lock, std::chrono::seconds(1), [&] {
              return stopping || closed || snapshot_version != *sent_version ||
                     events_next() != *sent_events;
            });
            if (stopping) return false;
            const auto now = SteadyClock::now();
            // The last state of a run that is over goes out at once, whatever the rate.
            if (snapshot_version != *sent_version &&
                (closed || now - *last_state >= kStatePeriod)) {
              out += "event: state\ndata: " + dump_json(state_json()) + "\n\n";
              *sent_version = snapshot_version;
              *last_state = now;
            }
            if (events_next() != *sent_events) {
              out += "event: events\ndata: " + dump_json(events_json(*sent_events)) + "\n\n";
              *sent_events = events_next();
            }
            ended = closed && snapshot_version == *sent_version;
            if (ended) out += "event: end\ndata: {}\n\n";
          }
          // A comment keeps the connection's liveness known while nothing changes.
          if (out.empty() && idle) out = ": idle\n\n";
          // A browser that stopped reading fails the write (after the write timeout, on this
          // thread only): the stream ends, the tour never notices.
          if (!out.empty() && !sink.write(out.data(), out.size())) return false;
          if (ended) {
            sink.done();
            return false;
          }
          // At most ten writes a second however fast the tour runs: batches, not a spin.
          if (!idle) std::this_thread::sleep_for(std::chrono::milliseconds(100));
          return true;
        },
        [this](bool) {
          std::lock_guard<std::mutex> lock(mutex);
          --open_streams;
          changed.notify_all();
        });
  }

  // A control request, handed to the tour's thread and answered with its reply.
  void control(const httplib::Request& req, httplib::Response& res) {
    if (!authorised(req)) {
      return json_reply(res, 401,
                        {{"error", "control needs the run's token: Authorization: Bearer TOKEN"}});
    }
    if (!controls.take()) return json_reply(res, 429, {{"error", "too many control requests"}});
    const std::string request = req.matches[1].str();
    static const char* const kKnown[] = {"pause", "resume", "cancel", "skip", "retry"};
    if (std::find(std::begin(kKnown), std::end(kKnown), request) == std::end(kKnown)) {
      return json_reply(res, 404, {{"error", "no control \"" + request + "\""}});
    }
    auto pending_control = std::make_shared<PendingControl>();
    pending_control->control.request = request;
    pending_control->control.target = req.has_param("target") ? req.get_param_value("target") : "";
    if (request == "retry" && pending_control->control.target.empty()) {
      return json_reply(res, 400, {{"error", "retry needs ?target=ID"}});
    }
    std::future<MonitorReply> reply = pending_control->reply.get_future();
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (closed) return json_reply(res, 409, {{"error", "the run is over"}});
      pending.push_back(pending_control);
    }
    if (reply.wait_for(kControlWait) != std::future_status::ready) {
      return json_reply(res, 503, {{"error", "the tour did not take the request in time"}});
    }
    const MonitorReply r = reply.get();
    json_reply(res, 200, {{"accepted", r.accepted}, {"message", r.message}});
  }

  void render_map() {
    if (!fixed.map) return;
    const auto& m = *fixed.map;
    const int w = static_cast<int>(m.getSizeX());
    const int h = static_cast<int>(m.getSizeY());
    cv::Mat img(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        // Row 0 is the map's largest y, as a picture is read.
        img.at<std::uint8_t>(h - 1 - y, x) =
            static_cast<std::uint8_t>(std::clamp(m.getCell(x, y), 0.0f, 1.0f) * 255.0f);
      }
    }
    std::vector<unsigned char> bytes;
    cv::imencode(".png", img, bytes);
    map_png.assign(bytes.begin(), bytes.end());
    map_meta = Json{{"width_px", w},
                    {"height_px", h},
                    {"resolution_m", m.getResolution()},
                    {"x_min_m", m.getXMin()},
                    {"y_min_m", m.getYMin()}};
  }

  void describe_machine() {
    Json states = Json::array();
    for (const StateSpec* s : fixed.machine->states()) {
      Json children = Json::array();
      for (const auto& c : s->children) children.push_back(c->path);
      Json transitions = Json::array();
      for (const TransitionSpec& t : s->on) {
        for (const std::string& to : t.targets) {
          transitions.push_back({{"outcome", t.outcome}, {"to", to}});
        }
      }
      states.push_back({{"path", s->path},
                        {"name", s->name},
                        {"kind", s->is_leaf()        ? "leaf"
                                 : s->is_composite() ? "composite"
                                                     : "final"},
                        {"behaviour", s->behaviour},
                        {"initial", s->initial},
                        {"for_each", s->for_each_target},
                        {"children", std::move(children)},
                        {"transitions", std::move(transitions)}});
    }
    machine_json = Json{{"root", fixed.machine->root().path}, {"states", std::move(states)}};
  }
};

MonitorOptions parse_monitor_address(const std::string& text) {
  MonitorOptions o;
  std::string port_text = text;
  const std::size_t colon = text.rfind(':');
  if (colon != std::string::npos) {
    o.host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
    if (o.host.size() >= 2 && o.host.front() == '[' && o.host.back() == ']') {
      o.host = o.host.substr(1, o.host.size() - 2);
    }
    if (o.host.empty()) {
      throw std::invalid_argument("--monitor " + text +
                                  ": expected [HOST:]PORT, the host is empty");
    }
  }
  char* end = nullptr;
  const long port = std::strtol(port_text.c_str(), &end, 10);
  if (port_text.empty() || *end != '\0' || port < 0 || port > 65535) {
    throw std::invalid_argument("--monitor " + text +
                                ": expected [HOST:]PORT with PORT from 0 (any free one) to 65535");
  }
  o.port = static_cast<int>(port);
  return o;
}

bool is_loopback_host(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

std::string make_monitor_token() {
  std::ifstream random("/dev/urandom", std::ios::binary);
  unsigned char bytes[16];
  if (!random.read(reinterpret_cast<char*>(bytes), sizeof bytes)) {
    throw std::runtime_error("cannot read /dev/urandom for the monitor's token");
  }
  std::string token;
  char hex[3];
  for (unsigned char b : bytes) {
    std::snprintf(hex, sizeof hex, "%02x", b);
    token += hex;
  }
  return token;
}

MonitorServer::MonitorServer(MonitorOptions options, Fixed fixed)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(fixed))) {
  impl_->render_map();
  if (impl_->fixed.machine != nullptr) impl_->describe_machine();
  impl_->routes();
  const MonitorOptions& o = impl_->options;
  if (o.port == 0) {
    impl_->port = impl_->server.bind_to_any_port(o.host);
  } else if (impl_->server.bind_to_port(o.host, o.port)) {
    impl_->port = o.port;
  } else {
    impl_->port = -1;
  }
  if (impl_->port <= 0) {
    throw std::runtime_error("cannot serve the monitor on " + o.host + ":" +
                             std::to_string(o.port) + " (in use, or not an address of this host)");
  }
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
}

MonitorServer::~MonitorServer() {
  close();
  {
    // The open streams get a moment to send the run's last state and `end`.
    std::unique_lock<std::mutex> lock(impl_->mutex);
    impl_->changed.wait_for(lock, std::chrono::seconds(1),
                            [&] { return impl_->open_streams == 0; });
  }
  impl_->stopping = true;
  impl_->changed.notify_all();
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

int MonitorServer::port() const {
  return impl_->port;
}

void MonitorServer::publish(MonitorSnapshot snapshot) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->snapshot = std::move(snapshot);
  ++impl_->snapshot_version;
  impl_->changed.notify_all();
}

bool MonitorServer::wants_frame(const std::string& kind) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const auto it = impl_->frames.find(kind);
  return it == impl_->frames.end() || SteadyClock::now() - it->second.taken >= kFramePeriod;
}

void MonitorServer::publish_frame(const std::string& kind, const cv::Mat& image) {
  if (image.empty() || !wants_frame(kind)) return;
  cv::Mat small;
  const double scale = std::min(1.0, static_cast<double>(kFrameWidthPx) / image.cols);
  cv::resize(image, small, cv::Size(), scale, scale, cv::INTER_AREA);
  if (small.type() == CV_16UC1) {
    // Depth in mm: 0.3 m white to 4 m black, no reading black too.
    cv::Mat grey;
    small.convertTo(grey, CV_8UC1, -255.0 / 3700.0, 255.0 * 4000.0 / 3700.0);
    grey.setTo(0, small == 0);
    cv::applyColorMap(grey, small, cv::COLORMAP_BONE);
  }
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Frame& f = impl_->frames[kind];
  f.small = small;
  f.png.clear();
  ++f.sequence;
  f.taken = SteadyClock::now();
  ++impl_->snapshot_version;
  impl_->changed.notify_all();
}

void MonitorServer::drain_controls(
    const std::function<MonitorReply(const MonitorControl&)>& handle) {
  std::deque<std::shared_ptr<PendingControl>> taken;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    taken.swap(impl_->pending);
  }
  for (auto& p : taken) {
    MonitorReply reply;
    try {
      reply = handle(p->control);
    } catch (const std::exception& e) {
      reply = {false, e.what()};
    }
    p->reply.set_value(reply);
  }
}

void MonitorServer::close() {
  std::deque<std::shared_ptr<PendingControl>> left;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->closed = true;
    left.swap(impl_->pending);
    impl_->changed.notify_all();
  }
  for (auto& p : left) p->reply.set_value({false, "the run is over"});
}

void MonitorServer::on_event(const ExecutorEvent& event) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (event.type == EventType::enter) {
    // A visit starts with its for_each's enter event carrying the target: a fresh trail.
    const StateSpec* s =
        impl_->fixed.machine != nullptr ? impl_->fixed.machine->find(event.state) : nullptr;
    if (s != nullptr && s->for_each_target) impl_->trail.clear();
    if (s == nullptr || s->is_leaf()) impl_->trail.push_back(event.state);
  }
  impl_->events.push_back(Json(event));
  if (impl_->events.size() > kEventsKept) {
    impl_->events.pop_front();
    ++impl_->events_first;
  }
  impl_->changed.notify_all();
}

}  // namespace projtour
