#include "monitor_hookup.hpp"

#include <algorithm>
#include <fstream>
#include <opencv2/core.hpp>
#include <ostream>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/contract/run_files.hpp"

namespace projtour {
namespace {

constexpr const char* kDefaultHardwareMonitor = "127.0.0.1:8470";

std::string read_token_file(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("--monitor-token " + file.string() + ": cannot read it");
  std::string token;
  std::getline(in, token);
  while (!token.empty() && (token.back() == '\r' || token.back() == ' ')) token.pop_back();
  if (token.size() < 16 || token.size() > 256) {
    throw std::runtime_error("--monitor-token " + file.string() +
                             ": expected one line of 16 to 256 characters");
  }
  for (char c : token) {
    if (c <= ' ' || c > '~') {
      throw std::runtime_error("--monitor-token " + file.string() +
                               ": expected printable characters without spaces");
    }
  }
  return token;
}

// Forwards everything to the device; keeps what was shown for the monitor.
class TappedProjector : public ProjectorDriver {
 public:
  TappedProjector(std::shared_ptr<ProjectorDriver> inner, MonitorServer& monitor)
      : inner_(std::move(inner)), monitor_(monitor) {}
  void update(double t_s) override { inner_->update(t_s); }
  void safe_stop() override { inner_->safe_stop(); }
  GroundTruth* ground_truth() override { return inner_->ground_truth(); }
  void show(const cv::Mat& frame_bgr) override {
    inner_->show(frame_bgr);
    monitor_.publish_frame("projector", frame_bgr);
  }
  void blank() override { inner_->blank(); }
  bool is_blank() const override { return inner_->is_blank(); }

 private:
  std::shared_ptr<ProjectorDriver> inner_;
  MonitorServer& monitor_;
};

class TappedColourCamera : public ColourCameraDriver {
 public:
  TappedColourCamera(std::shared_ptr<ColourCameraDriver> inner, MonitorServer& monitor)
      : inner_(std::move(inner)), monitor_(monitor) {}
  void update(double t_s) override { inner_->update(t_s); }
  void safe_stop() override { inner_->safe_stop(); }
  GroundTruth* ground_truth() override { return inner_->ground_truth(); }
  std::optional<ColourFrame> grab() override {
    std::optional<ColourFrame> frame = inner_->grab();
    if (frame && !frame->bgr.empty() && monitor_.wants_frame("colour")) {
      const cv::Mat image(frame->height, frame->width, CV_8UC3, frame->bgr.data());
      monitor_.publish_frame("colour", image);
    }
    return frame;
  }
  void set_exposure_ms(double exposure_ms) override { inner_->set_exposure_ms(exposure_ms); }

 private:
  std::shared_ptr<ColourCameraDriver> inner_;
  MonitorServer& monitor_;
};

bool same_path(const std::vector<Pose2D>& a, const std::vector<Pose2D>& b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](const Pose2D& p, const Pose2D& q) {
           return p.x_m == q.x_m && p.y_m == q.y_m && p.yaw_rad == q.yaw_rad;
         });
}

}  // namespace

std::unique_ptr<MonitorServer> start_monitor(const RunOptions& options, const PreparedRun& prepared,
                                             const std::filesystem::path& run_dir,
                                             std::ostream& err) {
  if (options.no_monitor) {
    if (options.monitor) throw std::runtime_error("--monitor and --no-monitor contradict");
    return nullptr;
  }
  const bool asked = options.monitor.has_value();
  if (!asked && options.dry_run) return nullptr;
  MonitorOptions o;
  try {
    o = parse_monitor_address(asked ? *options.monitor : kDefaultHardwareMonitor);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  if (!is_loopback_host(o.host)) {
    if (!options.monitor_token_file) {
      throw std::runtime_error("--monitor " + *options.monitor +
                               " is not a loopback address: serving it needs --monitor-token FILE "
                               "(a token of your own, not one printed to a terminal)");
    }
    err << "projtour: warning: the monitor is served on " << o.host
        << ", reachable from other machines; its controls need the token\n";
  }
  o.token = options.monitor_token_file ? read_token_file(*options.monitor_token_file)
                                       : make_monitor_token();
  MonitorServer::Fixed fixed;
  fixed.mission = prepared.mission.name;
  fixed.dry_run = options.dry_run;
  fixed.machine = prepared.machine ? &*prepared.machine : nullptr;
  fixed.map = prepared.map;
  for (const auto& t : prepared.mission.targets) {
    fixed.targets.push_back({t.id, pose2d_from_isometry(t.T_map_model)});
  }
  std::unique_ptr<MonitorServer> monitor;
  try {
    monitor = std::make_unique<MonitorServer>(o, std::move(fixed));
  } catch (const std::exception& e) {
    if (asked) throw;
    err << "projtour: warning: no monitor: " << e.what() << " (--monitor PORT for another)\n";
    return nullptr;
  }
  write_private_run_file(run_dir / "monitor_token", o.token + "\n");
  err << "projtour: monitor on http://"
      << (o.host.find(':') != std::string::npos ? "[" + o.host + "]" : o.host) << ":"
      << monitor->port() << "/ (control token in " << (run_dir / "monitor_token").string();
  // A token of the user's own is theirs already; a made-up one is told once, at the start.
  if (!options.monitor_token_file) err << ": " << o.token;
  err << ")\n";
  return monitor;
}

void tap_frames(DriverSet& drivers, MonitorServer& monitor) {
  if (drivers.projector) {
    drivers.projector = std::make_shared<TappedProjector>(drivers.projector, monitor);
  }
  if (drivers.colour_camera) {
    drivers.colour_camera = std::make_shared<TappedColourCamera>(drivers.colour_camera, monitor);
  }
}

MonitorPublisher::MonitorPublisher(MonitorServer& monitor, const Executor& executor,
                                   const RunContext& run)
    : monitor_(monitor), executor_(executor), run_(run) {}

void MonitorPublisher::publish() {
  MonitorSnapshot s;
  s.mission_s = run_.clock->now_s();
  s.active_state = executor_.active_state();
  if (const auto t = executor_.current_target()) s.target = run_.mission->targets[*t].id;
  s.paused = executor_.paused();
  s.finished = executor_.finished();
  s.outcome = s.finished ? to_string(executor_.outcome()) : "";
  if (const PoseEstimate2D* e = run_.blackboard->find(keys::kLocalization)) s.estimate = e->mean;
  if (GroundTruth* truth = run_.drivers != nullptr ? run_.drivers->ground_truth() : nullptr) {
    s.truth = pose2d_from_isometry(truth->true_T_map_base());
    s.people = truth->people_positions();
  }
  if (run_.blackboard->writes() != seen_writes_) {
    seen_writes_ = run_.blackboard->writes();
    const NavigateResult* navigated = run_.blackboard->find(keys::kNavigate);
    if (navigated == nullptr) {
      plan_.reset();
    } else if (!plan_ || !same_path(*plan_, navigated->planned_path)) {
      plan_ = std::make_shared<const std::vector<Pose2D>>(navigated->planned_path);
    }
    const CapturedFrame* captured = run_.blackboard->find(keys::kCapture);
    if (captured != nullptr && captured->frame.sequence != depth_sequence_ &&
        !captured->frame.depth_mm.empty() && monitor_.wants_frame("depth")) {
      depth_sequence_ = captured->frame.sequence;
      const cv::Mat depth(captured->frame.height, captured->frame.width, CV_16UC1,
                          const_cast<std::uint16_t*>(captured->frame.depth_mm.data()));
      monitor_.publish_frame("depth", depth);
    }
  }
  // Records are appended to or, by a retry, have one taken out: a change shows in the count or
  // the last one.
  const auto& records = executor_.records();
  if (!records_ || records_->size() != records.size() ||
      (!records.empty() && (records_->back().id != records.back().id ||
                            records_->back().outcome != records.back().outcome))) {
    records_ = std::make_shared<const std::vector<TargetRecord>>(records);
  }
  s.plan = plan_;
  s.records = records_;
  monitor_.publish(std::move(s));
}

}  // namespace projtour
