#include "dry_run.hpp"

#include <algorithm>
#include <optional>
#include <stdexcept>

namespace projtour::integration {

namespace {

// The leaf states of a visit: "tour/visit/capture" (any machine whose visit is one level deep).
bool is_visit_step(const std::string& state) {
  return std::count(state.begin(), state.end(), '/') == 2;
}
std::string last_component(const std::string& state) {
  return state.substr(state.rfind('/') + 1);
}
bool has_target(const Json& event, const std::string& target) {
  const auto t = event.find("target");
  return t != event.end() && t->is_string() && t->get<std::string>() == target;
}

}  // namespace

fs::path data_dir() {
  return fs::path(PROJTOUR_SOURCE_DIR) / "tests" / "integration" / "data";
}

std::vector<std::string> dry_run_args(const fs::path& mission, const fs::path& world,
                                      const fs::path& out, const std::vector<std::string>& extra) {
  std::vector<std::string> args = {
      "run",        mission.string(), "--dry-run",
      "--world",    world.string(),   "--out",
      out.string(), "--plugin-path",  test::plugin_build_dir().string()};
  // Without --speed a dry run runs as fast as it can; `extra` may pace it.
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

std::vector<StepOutcome> step_outcomes(const std::vector<Json>& events, const std::string& target) {
  std::vector<StepOutcome> out;
  for (const Json& e : events) {
    if (e.at("event").get<std::string>() != "outcome" || !has_target(e, target)) continue;
    const std::string& state = e.at("state").get<std::string>();
    if (!is_visit_step(state)) continue;
    const auto message = e.find("message");
    out.push_back({last_component(state), e.at("outcome").get<std::string>(),
                   message != e.end() ? message->get<std::string>() : "", e.at("t").get<double>()});
  }
  return out;
}

std::vector<std::string> outcome_chain(const std::vector<Json>& events, const std::string& target) {
  std::vector<std::string> chain;
  for (const Json& e : events) {
    if (!has_target(e, target)) continue;
    const std::string& type = e.at("event").get<std::string>();
    const std::string& state = e.at("state").get<std::string>();
    if (!is_visit_step(state)) continue;
    if (type == "outcome") {
      chain.push_back(last_component(state) + ":" + e.at("outcome").get<std::string>());
    } else if (type == "transition") {
      const std::string& to = e.at("to").get<std::string>();
      if (to == "skip_target" || to == "finish" || to == "abort") chain.push_back(to);
    }
  }
  return chain;
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : " > ") + s;
  return out;
}

const Json& report_target(const Json& report, const std::string& id) {
  for (const Json& t : report.at("targets")) {
    if (t.at("id").get<std::string>() == id) return t;
  }
  throw std::runtime_error("report.json has no target " + id);
}

int shows_on(const fs::path& run_dir, const std::string& target) {
  int shows = 0;
  for (const Json& e : read_jsonl(run_dir / "sim_projector_log.jsonl")) {
    if (e.at("event").get<std::string>() != "show") continue;
    shows += target.empty() ||
             (e.at("target").is_string() && e.at("target").get<std::string>() == target);
  }
  return shows;
}

std::vector<std::string> projector_safety_problems(const fs::path& run_dir,
                                                   const std::vector<Json>& events,
                                                   std::size_t first_log_line) {
  // Mission seconds in the projector log are printed with six significant digits.
  constexpr double kSlackS = 0.01;
  // The steps that light the projector: the structured light, the verification, the content.
  const auto lights = [](const std::string& step) {
    return step == "calibrate" || step == "verify" || step == "project";
  };
  std::vector<std::pair<double, double>> project_spells;
  std::optional<double> entered_s;
  for (const Json& e : events) {
    if (!is_visit_step(e.at("state").get<std::string>()) ||
        !lights(last_component(e.at("state").get<std::string>()))) {
      continue;
    }
    if (e.at("event").get<std::string>() == "enter") entered_s = e.at("t").get<double>();
    if (e.at("event").get<std::string>() == "exit" && entered_s) {
      project_spells.emplace_back(*entered_s, e.at("t").get<double>());
      entered_s.reset();
    }
  }
  const auto inside_project = [&](double from_s, double to_s) {
    for (const auto& [a, b] : project_spells) {
      if (from_s >= a - kSlackS && to_s <= b + kSlackS) return true;
    }
    return false;
  };

  std::vector<std::string> problems;
  const std::vector<Json> log = read_jsonl(run_dir / "sim_projector_log.jsonl");
  if (first_log_line > log.size()) {
    return {"sim_projector_log.jsonl has " + std::to_string(log.size()) +
            " lines, fewer than the " + std::to_string(first_log_line) + " of the run before"};
  }
  std::optional<double> lit_since_s;
  for (auto it = log.begin() + static_cast<std::ptrdiff_t>(first_log_line); it != log.end(); ++it) {
    const Json& e = *it;
    const double t_s = e.at("t").get<double>();
    const bool show = e.at("event").get<std::string>() == "show";
    const bool moving = e.at("base_moving").get<bool>() || e.at("head_moving").get<bool>();
    const std::string at = " at t=" + json_number_text(t_s) + " s (" + e.dump() + ")";
    if (show) {
      if (moving) problems.push_back("shown while the base or head moved" + at);
      if (!lit_since_s) lit_since_s = t_s;
      continue;
    }
    if (!lit_since_s) continue;  // blanking a blank projector
    if (moving) problems.push_back("still lit when the base or head moved" + at);
    if (!inside_project(*lit_since_s, t_s)) {
      problems.push_back("lit from t=" + json_number_text(*lit_since_s) + " s to t=" +
                         json_number_text(t_s) + " s outside a calibrate, verify or project state");
    }
    lit_since_s.reset();
  }
  if (lit_since_s) {
    problems.push_back("left lit at the end of the run (since t=" + json_number_text(*lit_since_s) +
                       " s)");
  }
  return problems;
}

}  // namespace projtour::integration
