#include "in_process_run.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>

#include "projtour/ground_truth.hpp"

namespace projtour::integration {

namespace {

using Calls = std::shared_ptr<std::vector<DeviceCall>>;

class RecordingPanTilt : public PanTiltDriver {
 public:
  RecordingPanTilt(std::shared_ptr<PanTiltDriver> inner, Calls calls, const Clock& clock)
      : inner_(std::move(inner)), calls_(std::move(calls)), clock_(clock) {}
  void update(double t_s) override { inner_->update(t_s); }
  void safe_stop() override {
    note("pan_tilt safe_stop");
    inner_->safe_stop();
  }
  GroundTruth* ground_truth() override { return inner_->ground_truth(); }
  void command(const JointAngles& angles) override {
    note("pan_tilt command");
    inner_->command(angles);
  }
  JointAngles measured() const override { return inner_->measured(); }
  bool reached() const override { return inner_->reached(); }

 private:
  void note(const char* call) { calls_->push_back({clock_.now_s(), call}); }
  std::shared_ptr<PanTiltDriver> inner_;
  Calls calls_;
  const Clock& clock_;
};

class RecordingProjector : public ProjectorDriver {
 public:
  RecordingProjector(std::shared_ptr<ProjectorDriver> inner, Calls calls, const Clock& clock)
      : inner_(std::move(inner)), calls_(std::move(calls)), clock_(clock) {}
  void update(double t_s) override { inner_->update(t_s); }
  void safe_stop() override {
    note("projector safe_stop");
    inner_->safe_stop();
  }
  GroundTruth* ground_truth() override { return inner_->ground_truth(); }
  void show(const cv::Mat& frame_bgr) override {
    note("projector show");
    inner_->show(frame_bgr);
  }
  void blank() override {
    note("projector blank");
    inner_->blank();
  }
  bool is_blank() const override { return inner_->is_blank(); }

 private:
  void note(const char* call) { calls_->push_back({clock_.now_s(), call}); }
  std::shared_ptr<ProjectorDriver> inner_;
  Calls calls_;
  const Clock& clock_;
};

std::string last_component(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

}  // namespace

InProcessRun::InProcessRun(const std::filesystem::path& mission, const std::filesystem::path& world,
                           const std::filesystem::path& run_dir, std::uint64_t seed)
    : calls_(std::make_shared<std::vector<DeviceCall>>()) {
  RunOptions options;
  options.mission = mission;
  options.dry_run = true;
  options.world = world;
  options.plugin_paths = {PROJTOUR_PLUGIN_BUILD_DIR};
  Diagnostics diag;
  prepared_ = prepare_run(options, PrepareDepth::everything, diag);
  if (!prepared_) {
    std::string problems;
    for (const auto& d : diag.items()) problems += d.format() + "\n";
    throw std::runtime_error("cannot prepare " + mission.string() + ":\n" + problems);
  }
  std::filesystem::create_directories(run_dir / "targets");
  run_.mission = &prepared_->mission;
  run_.world = prepared_->world ? &*prepared_->world : nullptr;
  run_.dry_run = true;
  run_.seed = seed;
  run_.run_dir = run_dir;
  run_.map = prepared_->map;
  run_.drivers = &drivers_;
  run_.blackboard = &blackboard_;
  run_.clock = &clock_;
  run_.log = &logger_;
  const PluginRegistry& registry = *prepared_->registry;
  for (const auto& [interface, choice] : prepared_->drivers) {
    auto d = registry.create_driver(choice.kind, choice.params, run_);
    if (interface == "base") drivers_.base = std::dynamic_pointer_cast<BaseDriver>(d);
    if (interface == "laser") drivers_.laser = std::dynamic_pointer_cast<LaserDriver>(d);
    if (interface == "depth_camera") {
      drivers_.depth_camera = std::dynamic_pointer_cast<DepthCameraDriver>(d);
    }
    if (interface == "colour_camera") {
      drivers_.colour_camera = std::dynamic_pointer_cast<ColourCameraDriver>(d);
    }
    if (interface == "pan_tilt") {
      drivers_.pan_tilt = std::make_shared<RecordingPanTilt>(
          std::dynamic_pointer_cast<PanTiltDriver>(d), calls_, clock_);
    }
    if (interface == "projector") {
      drivers_.projector = std::make_shared<RecordingProjector>(
          std::dynamic_pointer_cast<ProjectorDriver>(d), calls_, clock_);
    }
  }
  std::vector<ServiceInstance> services;
  for (const auto& [role, choice] : prepared_->services) {
    services.push_back(
        {role, registry.create_service(choice.kind, choice.params, run_), choice.params});
  }
  auto behaviours = create_behaviours(*prepared_->machine, *prepared_->catalog, run_);
  ExecutorOptions executor_options;
  tick_s_ = executor_options.tick_s;
  executor_ = std::make_unique<Executor>(*prepared_->machine, std::move(behaviours),
                                         std::move(services), run_, clock_, executor_options);
  executor_->add_observer(this);
}

InProcessRun::~InProcessRun() = default;

void InProcessRun::on_event(const ExecutorEvent& event) {
  events_.push_back(event);
  // As the command's VisitToTruth: the simulated world shows the visited target's object.
  if (event.type != EventType::enter || !event.target) return;
  if (GroundTruth* truth = drivers_.ground_truth()) truth->set_visited_target(*event.target);
}

bool InProcessRun::step_until(const std::string& state, const std::string& target) {
  for (;;) {
    const std::string active = executor_->active_state();
    const auto index = executor_->current_target();
    if (!active.empty() && last_component(active) == state && index &&
        run_.mission->targets[*index].id == target) {
      return true;
    }
    if (!executor_->step()) return false;
  }
}

void InProcessRun::steps(int n) {
  for (int i = 0; i < n && executor_->step(); ++i) {
  }
}

void InProcessRun::paused_for(int ticks) {
  executor_->pause();
  steps(ticks);
}

TourOutcome InProcessRun::run_to_end() {
  return executor_->run_to_end();
}

std::vector<std::string> InProcessRun::device_calls_from(std::size_t from) const {
  std::vector<std::string> out;
  for (std::size_t i = from; i < calls_->size(); ++i) out.push_back((*calls_)[i].call);
  return out;
}

std::vector<std::string> InProcessRun::outcomes(const std::string& target) const {
  std::vector<std::string> out;
  for (const auto& e : events_) {
    if (e.type != EventType::outcome || !e.target || *e.target != target) continue;
    // Leaf states only: the for_each's own "done" is not a step.
    if (e.state.find("/visit/") == std::string::npos) continue;
    out.push_back(last_component(e.state) + ":" + e.outcome);
  }
  return out;
}

}  // namespace projtour::integration
