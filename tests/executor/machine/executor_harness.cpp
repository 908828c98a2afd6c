#include "executor_harness.hpp"

#include <algorithm>
#include <sstream>

#include "projtour/host/params_reader.hpp"

namespace projtour::testing {

namespace {

std::string strip_root(const std::string& path) {
  const auto slash = path.find('/');
  if (slash == std::string::npos) return path;
  return path.substr(slash + 1);
}

}  // namespace

std::string describe(const ExecutorEvent& e) {
  std::string s = std::string(to_string(e.type)) + " " + strip_root(e.state);
  if (e.type == EventType::outcome || e.type == EventType::transition) s += " " + e.outcome;
  if (e.type == EventType::transition) s += " -> " + strip_root(e.to);
  if (e.type == EventType::control) {
    s += " " + e.request + (e.retry_target.empty() ? "" : " " + e.retry_target) + " by " + e.by +
         (e.accepted ? "" : " refused");
  }
  if (e.target) s += " @" + *e.target;
  return s;
}

std::vector<std::string> Recorder::lines() const {
  std::vector<std::string> out;
  for (const auto& e : events) out.push_back(describe(e));
  return out;
}

::testing::AssertionResult sequence_is(const std::vector<std::string>& actual,
                                       const std::vector<std::string>& expected) {
  const std::size_t n = std::min(actual.size(), expected.size());
  std::size_t first = n;
  for (std::size_t i = 0; i < n; ++i) {
    if (actual[i] != expected[i]) {
      first = i;
      break;
    }
  }
  if (first == n && actual.size() == expected.size()) return ::testing::AssertionSuccess();
  std::ostringstream why;
  why << "sequences differ at event " << first << " (actual " << actual.size() << " events, "
      << "expected " << expected.size() << ")\n";
  const std::size_t from = first >= 3 ? first - 3 : 0;
  for (std::size_t i = from; i < std::max(actual.size(), expected.size()) && i < first + 6; ++i) {
    why << (i == first ? ">> " : "   ") << i << ": actual "
        << (i < actual.size() ? actual[i] : "<none>") << " | expected "
        << (i < expected.size() ? expected[i] : "<none>") << "\n";
  }
  return ::testing::AssertionFailure() << why.str();
}

std::vector<std::string> leaf(const std::string& path, const std::string& outcome,
                              const std::string& to, const std::string& target) {
  const std::string at = target.empty() ? "" : " @" + target;
  return {"enter " + path + at, "outcome " + path + " " + outcome + at, "exit " + path + at,
          "transition " + path + " " + outcome + " -> " + to + at};
}

std::vector<std::string> seq(std::initializer_list<std::vector<std::string>> parts) {
  std::vector<std::string> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

std::vector<std::string> happy_visit(const std::string& t) {
  return seq({{"enter visit @" + t},
              leaf("visit/navigate", "succeeded", "visit/aim", t),
              leaf("visit/aim", "succeeded", "visit/capture", t),
              leaf("visit/capture", "succeeded", "visit/align", t),
              leaf("visit/align", "succeeded", "visit/calibrate", t),
              leaf("visit/calibrate", "succeeded", "visit/verify", t),
              leaf("visit/verify", "verified", "visit/project", t),
              leaf("visit/project", "succeeded", "visit/next", t),
              leaf("visit/next", "succeeded", "finish", t),
              {"exit visit @" + t}});
}

Harness::Harness(std::vector<std::string> target_ids) {
  mission.name = "harness";
  for (const auto& id : target_ids) {
    TargetSpec t;
    t.id = id;
    mission.targets.push_back(t);
  }
  // A real run, not a dry run: no report figure may depend on a simulator's truth.
  rig.run.dry_run = false;
  for (const auto& [kind, outcomes] : tour_kinds()) {
    // Tour kinds take their script from the harness (the default machine gives no params);
    // "scripted" reads its params from the machine like the plugin does.
    const bool from_machine = kind == "scripted";
    catalog.add(
        kind, outcomes, from_machine ? scripted_param_specs() : std::vector<ParamSpec>{},
        [this, kind = kind, from_machine](const Params& params, const RunContext& r) {
          const auto it = scripts_.find(kind);
          const Params& p = from_machine           ? params
                            : it != scripts_.end() ? it->second
                                                   : scripts_["__defaults"];
          return std::make_shared<ScriptedBehaviour>(p, r);
        },
        from_machine ? InProcessCatalog::Validator(validate_script)
                     : InProcessCatalog::Validator());
  }
  scripts_["__defaults"] = host::default_params(scripted_param_specs());
  script("verify", "verified");  // verify's success is "verified"
}

void Harness::script(const std::string& kind, const std::string& outcomes, long long ticks,
                     long long throw_on, bool ignore_cancel) {
  Params p = host::default_params(scripted_param_specs());
  p.set("outcomes", outcomes);
  p.set("ticks", ticks);
  p.set("throw_on", throw_on);
  p.set("ignore_cancel", ignore_cancel);
  scripts_[kind] = p;
}

std::optional<Machine> Harness::parse(const std::string& yaml, host::Diagnostics& diag) const {
  const auto node = host::load_yaml_string(yaml, "machine.yaml", diag);
  if (!node) return std::nullopt;
  return load_machine(host::YamlField(*node, "machine.yaml", diag), catalog, diag);
}

void Harness::load_default() {
  host::Diagnostics diag;
  machine = load_machine(host::MachineSource{}, catalog, diag);
  ASSERT_TRUE(machine.has_value()) << diag.format();
}

void Harness::load(const std::string& yaml) {
  host::Diagnostics diag;
  machine = parse(yaml, diag);
  ASSERT_TRUE(machine.has_value()) << diag.format();
}

void Harness::build(ExecutorOptions options) {
  behaviours_ = create_behaviours(*machine, catalog, run_context);
  executor =
      std::make_unique<Executor>(*machine, behaviours_, services, run_context, clock, options);
  executor->add_observer(&recorder);
}

bool Harness::step_until(const std::string& path, const std::string& target, int max_ticks) {
  for (int i = 0; i < max_ticks; ++i) {
    if (!executor->finished() && executor->active_state() == machine->root().name + "/" + path &&
        executor->current_target() && mission.targets[*executor->current_target()].id == target) {
      return true;
    }
    if (!executor->step()) return false;
  }
  return false;
}

ScriptedBehaviour& Harness::behaviour(const std::string& path) {
  return dynamic_cast<ScriptedBehaviour&>(*behaviours_.at(machine->root().name + "/" + path));
}

}  // namespace projtour::testing
