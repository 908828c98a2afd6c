#pragma once
// A dry run of an integration mission inside the test process: the command's own RunSession
// opened and wired as `projtour run --dry-run` does (the real plugins on the simulated drivers,
// the run directory with its events and checkpoint), with the executor stepped by the test
// instead of the session's loop, so it can pause, resume and cancel at a chosen state. The
// projector and pan-tilt are wrapped as they are made so every call the tour makes on them is
// recorded.
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "projtour/machine/executor.hpp"
#include "projtour/tour/run_session.hpp"

namespace projtour::integration {

// Each recorded call with its mission time: "12.35 pan_tilt command", "projector show",
// "projector blank", "<device> safe_stop".
struct DeviceCall {
  double t_s = 0.0;
  std::string call;
};

class InProcessRun : public ExecutorObserver {
 public:
  InProcessRun(const std::filesystem::path& mission, const std::filesystem::path& world,
               const std::filesystem::path& run_dir, std::uint64_t seed = 1);
  ~InProcessRun() override;

  // Steps until the active leaf is `state` (last path component) in a visit to `target`;
  // false when the tour ends first.
  bool step_until(const std::string& state, const std::string& target);
  void steps(int n);
  // Steps n ticks, all paused (the clock goes on, the behaviour is not ticked).
  void paused_for(int ticks);
  TourOutcome run_to_end();

  Executor& executor() { return session_->executor(); }
  double tick_s() const { return session_->tick_s(); }
  const std::vector<DeviceCall>& device_calls() const { return *calls_; }
  // The calls from index `from` on, without their times.
  std::vector<std::string> device_calls_from(std::size_t from) const;
  // The outcomes of the leaf states of every visit to `target`: "navigate:succeeded".
  std::vector<std::string> outcomes(const std::string& target) const;

  void on_event(const ExecutorEvent& event) override;

 private:
  std::shared_ptr<std::vector<DeviceCall>> calls_;
  // What the command would print: the progress, and the problems that stop the set-up.
  std::ostringstream out_;
  std::ostringstream err_;
  std::unique_ptr<RunSession> session_;
  std::vector<ExecutorEvent> events_;
};

}  // namespace projtour::integration
