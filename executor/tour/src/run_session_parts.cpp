#include "run_session_parts.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <future>
#include <ostream>
#include <thread>

#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/blackboard_keys.hpp"

namespace projtour {

namespace {

// Atomics, not volatile sig_atomic_t: a signal may be delivered to any thread of the process
// (the watchdog's too), and only a lock-free atomic is both async-signal-safe and ordered
// across threads (ThreadSanitizer reported the volatile flags racing with the tick loop).
std::atomic<int> g_stop_signal{0};
std::atomic<int> g_pause_signal{0};
std::atomic<int> g_resume_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "signal flags must be lock-free atomics");

extern "C" void on_stop_signal(int signal) {
  g_stop_signal = signal;
}
extern "C" void on_pause_signal(int) {
  g_pause_signal = 1;
}
extern "C" void on_resume_signal(int) {
  g_resume_signal = 1;
}

// The pacing sleep, in slices: a signal acts within kSignalSlice of wall time at any --speed
// (a slowed-down dry run sleeps minutes per tick).
constexpr auto kSignalSlice = std::chrono::milliseconds(20);

}  // namespace

SignalScope::SignalScope() {
  g_stop_signal = g_pause_signal = g_resume_signal = 0;
  install(SIGINT, on_stop_signal, 0);
  install(SIGTERM, on_stop_signal, 1);
  install(SIGUSR1, on_pause_signal, 2);
  install(SIGUSR2, on_resume_signal, 3);
}

SignalScope::~SignalScope() {
  const int signals[] = {SIGINT, SIGTERM, SIGUSR1, SIGUSR2};
  for (int i = 0; i < 4; ++i) sigaction(signals[i], &previous_[i], nullptr);
}

void SignalScope::install(int signal, void (*handler)(int), int slot) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  sigaction(signal, &action, &previous_[slot]);
}

bool take_stop_signal() {
  return g_stop_signal.exchange(0) != 0;
}
bool take_pause_signal() {
  return g_pause_signal.exchange(0) != 0;
}
bool take_resume_signal() {
  return g_resume_signal.exchange(0) != 0;
}

void paced_sleep_until(std::chrono::steady_clock::time_point until) {
  while (g_stop_signal == 0 && g_pause_signal == 0 && g_resume_signal == 0) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= until) return;
    std::this_thread::sleep_for(
        std::min<std::chrono::steady_clock::duration>(until - now, kSignalSlice));
  }
}

void print_diagnostics(const host::Diagnostics& diag, std::ostream& err) {
  for (const auto& d : diag.items()) err << d.format() << "\n";
}

// --speed: positive and finite; below real time only where no real base waits on the ticks.
std::string speed_problem(const RunOptions& options) {
  if (!options.speed) return "";
  const double x = *options.speed;
  if (!std::isfinite(x) || !(x > 0.0)) return "--speed must be a positive, finite number";
  if (x < 1.0 && !options.dry_run) {
    return "--speed below 1 only in a dry run: on hardware a slowed tick loop would hold up the "
           "base's commands and the safe stop";
  }
  return "";
}

void assign_driver(DriverSet& set, const std::string& interface, std::shared_ptr<Driver> d) {
  if (interface == "base") set.base = std::dynamic_pointer_cast<BaseDriver>(d);
  if (interface == "laser") set.laser = std::dynamic_pointer_cast<LaserDriver>(d);
  if (interface == "pan_tilt") set.pan_tilt = std::dynamic_pointer_cast<PanTiltDriver>(d);
  if (interface == "depth_camera") {
    set.depth_camera = std::dynamic_pointer_cast<DepthCameraDriver>(d);
  }
  if (interface == "projector") set.projector = std::dynamic_pointer_cast<ProjectorDriver>(d);
  if (interface == "colour_camera") {
    set.colour_camera = std::dynamic_pointer_cast<ColourCameraDriver>(d);
  }
}

bool safe_stop_within(const DriverSet& drivers, std::chrono::seconds wait) {
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> stopped = done->get_future();
  std::thread([list = drivers.all(), done] {
    for (const auto& d : list) d->safe_stop();
    done->set_value();
  }).detach();
  return stopped.wait_for(wait) == std::future_status::ready;
}

void VisitToTruth::on_event(const ExecutorEvent& event) {
  if (truth_ == nullptr || event.type != EventType::enter || !event.target) return;
  if (*event.target == visited_) return;
  visited_ = *event.target;
  truth_->set_visited_target(visited_);
}

void TourTrace::sample() {
  const double t_s = run_.clock->now_s();
  if (t_s - last_sample_s_ < kSamplePeriodS) return;
  last_sample_s_ = t_s;
  if (const PoseEstimate2D* estimate = run_.blackboard->find(keys::kLocalization)) {
    estimated_.push_back(estimate->mean);
  }
  if (GroundTruth* truth = run_.drivers->ground_truth()) {
    true_.push_back(pose2d_from_isometry(truth->true_T_map_base()));
    for (const Eigen::Vector2d& p : truth->people_positions()) people_.push_back(p);
  }
  if (const NavigateResult* navigated = run_.blackboard->find(keys::kNavigate)) {
    visit_path_ = navigated->planned_path;
  }
}

void TourTrace::on_target_done(const TargetRecord&) {
  if (!visit_path_.empty()) paths_.push_back(simplify_polyline(visit_path_, kToleranceM));
  visit_path_.clear();
  simplify_tail(estimated_, estimated_simplified_);
  simplify_tail(true_, true_simplified_);
}

TourPictureInput TourTrace::picture(const MissionSpec& mission,
                                    const std::vector<TargetRecord>& records) const {
  TourPictureInput input;
  input.map = run_.map;
  input.start = mission.start;
  input.title = mission.name;
  for (const auto& target : mission.targets) {
    TourPictureTarget t{target.id, pose2d_from_isometry(target.T_map_model), ""};
    for (const auto& r : records) {
      if (r.id == target.id) t.outcome = r.outcome;
    }
    input.targets.push_back(std::move(t));
  }
  input.planned_paths = paths_;
  if (!visit_path_.empty()) input.planned_paths.push_back(visit_path_);
  input.estimated_trajectory = estimated_;
  input.true_trajectory = true_;
  input.people_samples = people_;
  return input;
}

void TourTrace::simplify_tail(std::vector<Pose2D>& line, std::size_t& simplified) {
  const std::size_t first = simplified == 0 ? 0 : simplified - 1;
  const std::vector<Pose2D> tail =
      simplify_polyline(std::vector<Pose2D>(line.begin() + first, line.end()), kToleranceM);
  line.erase(line.begin() + first, line.end());
  line.insert(line.end(), tail.begin(), tail.end());
  simplified = line.size();
}

}  // namespace projtour
