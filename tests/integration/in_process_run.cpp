#include "in_process_run.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

#include "projtour/contract/ground_truth.hpp"
#include "projtour/tour/run_session.hpp"

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
  options.seed = seed;
  options.out = run_dir;
  options.plugin_paths = {PROJTOUR_PLUGIN_BUILD_DIR};
  // The tests' tours are no showings: they stay out of the user's history database.
  options.no_history = true;
  session_ = std::make_unique<RunSession>(options, out_, err_);
  session_->set_driver_wrap(
      [this](const std::string& interface, std::shared_ptr<Driver> d) -> std::shared_ptr<Driver> {
        const Clock& clock = session_->clock();
        if (interface == "pan_tilt") {
          return std::make_shared<RecordingPanTilt>(std::dynamic_pointer_cast<PanTiltDriver>(d),
                                                    calls_, clock);
        }
        if (interface == "projector") {
          return std::make_shared<RecordingProjector>(std::dynamic_pointer_cast<ProjectorDriver>(d),
                                                      calls_, clock);
        }
        return d;
      });
  if (session_->open() || session_->wire()) {
    throw std::runtime_error("cannot set up a run of " + mission.string() + ":\n" + err_.str());
  }
  session_->executor().add_observer(this);
}

InProcessRun::~InProcessRun() = default;

void InProcessRun::on_event(const ExecutorEvent& event) {
  events_.push_back(event);
}

bool InProcessRun::step_until(const std::string& state, const std::string& target) {
  for (;;) {
    const std::string active = executor().active_state();
    const auto index = executor().current_target();
    if (!active.empty() && last_component(active) == state && index &&
        session_->context().mission->targets[*index].id == target) {
      return true;
    }
    if (!executor().step()) return false;
  }
}

void InProcessRun::steps(int n) {
  for (int i = 0; i < n && executor().step(); ++i) {
  }
}

void InProcessRun::paused_for(int ticks) {
  executor().pause();
  steps(ticks);
}

TourOutcome InProcessRun::run_to_end() {
  return executor().run_to_end();
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
