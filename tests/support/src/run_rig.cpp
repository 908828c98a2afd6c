#include "projtour_test/run_rig.hpp"

#include <iostream>

namespace projtour::test {

namespace {

const char* level_name(LogLevel level) {
  switch (level) {
    case LogLevel::debug:
      return "debug";
    case LogLevel::info:
      return "info";
    case LogLevel::warning:
      return "warning";
    case LogLevel::error:
      return "error";
  }
  return "?";
}

}  // namespace

void RecordingLogger::log(LogLevel level, const std::string& message) {
  entries_.push_back({level, message});
  if (level >= echo_) std::cerr << "[" << level_name(level) << "] " << message << "\n";
}

std::vector<std::string> RecordingLogger::messages(LogLevel at_least) const {
  std::vector<std::string> out;
  for (const Entry& e : entries_) {
    if (e.level >= at_least) out.push_back(e.message);
  }
  return out;
}

RunRig::RunRig(RunDir run_dir) {
  if (run_dir == RunDir::temp) {
    dir.emplace("run");
    run.run_dir = dir->path();
  }
  run.mission = &mission;
  run.dry_run = true;
  run.seed = 1;
  run.drivers = &drivers;
  run.blackboard = &blackboard;
  run.clock = &clock;
  run.log = &log;
}

Context RunRig::context(const Params* params, const std::string& state_path) const {
  Context ctx;
  ctx.run = &run;
  ctx.params = params;
  ctx.cancel = &cancel;
  ctx.state_path = state_path;
  return ctx;
}

Context RunRig::target_context(std::size_t index, const Params* params,
                               const std::string& state_path) const {
  Context ctx = context(params, state_path);
  ctx.target = &mission.targets.at(index);
  ctx.target_index = index;
  ctx.target_dir = run.run_dir / "targets" / ctx.target->id;
  std::filesystem::create_directories(ctx.target_dir);
  return ctx;
}

void RunRig::advance(double dt_s) {
  advance_to(clock.now_s() + dt_s);
}

void RunRig::advance_to(double t_s) {
  clock.set(t_s);
  for (const auto& d : drivers.all()) d->update(t_s);
}

}  // namespace projtour::test
