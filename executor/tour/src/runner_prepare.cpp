#include <mrpt/maps/COccupancyGridMap2D.h>

#include "projtour/host/mission_loader.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/tour/run_checks.hpp"
#include "projtour/tour/runner.hpp"

namespace projtour {

namespace {

const std::vector<std::string> kInterfaces = {"base",         "laser",     "pan_tilt",
                                              "depth_camera", "projector", "colour_camera"};

// Checks a robot-file instance (driver or service) against its kind and schema.
std::optional<InstanceChoice> check_instance(const host::PluginRegistry& registry,
                                             const host::PluginInstanceSpec& spec,
                                             host::Family family, const std::string& interface,
                                             const std::string& robot_file,
                                             host::Diagnostics& diag) {
  const std::string kind_path =
      spec.params_path.size() > 7
          ? spec.params_path.substr(0, spec.params_path.size() - 7) + ".kind"
          : "kind";
  const host::KindInfo* kind = registry.find(spec.kind);
  if (kind == nullptr) {
    std::vector<std::string> names;
    for (const host::KindInfo* k : registry.kinds()) {
      if (k->family == family) names.push_back(k->name);
    }
    std::string message = std::string("unknown ") + to_string(family) + " kind \"" + spec.kind +
                          "\" (is its plugin on the plugin path?)";
    const std::string suggestion = host::closest_match(spec.kind, names);
    if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
    diag.error(spec.mark, kind_path, message);
    return std::nullopt;
  }
  if (kind->family != family || kind->interface != interface) {
    diag.error(spec.mark, kind_path,
               "kind \"" + spec.kind + "\" is a " + to_string(kind->family) +
                   (kind->interface.empty() ? "" : " for \"" + kind->interface + "\"") +
                   ", not a " + to_string(family) + " for \"" + interface + "\"");
    return std::nullopt;
  }
  // Read the parameters with their own field path; marks come from the nodes themselves, and
  // problems with absent params point at the instance.
  host::Diagnostics local;
  YAML::Node wrapper;
  wrapper[spec.params_path] = spec.params;
  const Params params = host::read_params(
      kind->params, host::YamlField(wrapper, robot_file, local)[spec.params_path]);
  for (host::Diagnostic d : local.items()) {
    if (!spec.params.IsDefined() || spec.params.IsNull() || d.mark.line == 0 ||
        (d.mark.line == 1 && d.mark.column == 1 && spec.mark.line > 0)) {
      d.mark = spec.mark;
    }
    diag.add(d);
  }
  if (local.has_errors()) return std::nullopt;
  const std::string why = registry.validate_params(spec.kind, params);
  if (!why.empty()) {
    // A plugin names the parameter first ("particles: expected ..."): point at its line.
    const std::string name = why.substr(0, why.find(':'));
    if (name.size() < why.size() && spec.params.IsMap() && spec.params[name].IsDefined()) {
      const YAML::Mark m = spec.params[name].Mark();
      diag.error(host::SourceMark{robot_file, m.line + 1, m.column + 1},
                 spec.params_path + "." + name, why.substr(std::min(why.size(), name.size() + 2)));
    } else {
      diag.error(spec.mark, spec.params_path, why);
    }
    return std::nullopt;
  }
  return InstanceChoice{spec.kind, params};
}

}  // namespace

void report_map_problems(const host::LoadedMission& mission,
                         const std::vector<navigation::MapProblem>& problems,
                         host::Diagnostics& diag) {
  for (const navigation::MapProblem& problem : problems) {
    const bool written = mission.marks.count(problem.field_path) != 0;
    diag.error(mission.mark_of(written ? problem.field_path : problem.fallback_path),
               problem.field_path, problem.message);
  }
}

std::unique_ptr<PreparedRun> prepare_run(const RunOptions& options, PrepareDepth depth,
                                         host::Diagnostics& diag) {
  auto run = std::make_unique<PreparedRun>();
  auto mission = host::load_mission(options.mission, diag);
  if (!mission) return nullptr;
  run->mission = std::move(*mission);
  if (options.ros2_bridge && !options.dry_run) {
    diag.error(host::SourceMark{options.mission.string(), 0, 0}, "",
               "--ros2-bridge is only for a dry run (add --dry-run)");
  }
  if (options.world) {
    if (!options.dry_run) {
      diag.error(host::SourceMark{options.world->string(), 0, 0}, "",
                 "--world is only for a dry run (add --dry-run)");
    }
    run->world = host::load_world(*options.world, run->mission, diag);
    if (!run->world) return nullptr;
  } else if (options.dry_run) {
    run->world = host::WorldSpec{};  // the mission's nominal poses with default noise
  }

  run->registry = std::make_unique<host::PluginRegistry>(
      host::PluginLoadOptions{options.allow_writable_plugin_path});
  run->plugin_load_problems =
      run->registry->load_directories(host::PluginRegistry::search_path(options.plugin_paths));
  for (const auto& problem : run->plugin_load_problems) {
    diag.warning(host::SourceMark{}, "", "plugin not loaded: " + problem);
  }
  for (const auto& replaced : run->registry->warnings()) {
    diag.warning(host::SourceMark{}, "", "plugin not loaded: " + replaced);
  }
  run->catalog = std::make_unique<RegistryCatalog>(*run->registry);
  run->machine = load_machine(run->mission.machine, *run->catalog, diag);
  if (depth == PrepareDepth::machine) return diag.has_errors() ? nullptr : std::move(run);

  const std::string robot_file = run->mission.robot.file.string();
  if (options.dry_run) {
    // The simulated drivers take no parameters from files: they read robot and world from the
    // RunContext.
    for (const auto& interface : kInterfaces) {
      host::PluginInstanceSpec spec;
      const bool over_ros2 = options.ros2_bridge && (interface == "base" || interface == "laser");
      if (over_ros2 && run->mission.drivers.count(interface) &&
          run->mission.drivers.at(interface).kind == "ros2_" + interface) {
        spec = run->mission.drivers.at(interface);  // its parameters as the robot file gives them
      } else {
        spec.kind = (over_ros2 ? "ros2_" : "sim_") + interface;
        spec.params_path = "dry run: " + interface + " driver.params";
        spec.mark = run->mission.mark_of("robot");
      }
      if (auto c = check_instance(*run->registry, spec, host::Family::driver, interface, robot_file,
                                  diag)) {
        run->drivers[interface] = std::move(*c);
      }
    }
  } else {
    for (const auto& [interface, spec] : run->mission.drivers) {
      if (auto c = check_instance(*run->registry, spec, host::Family::driver, interface, robot_file,
                                  diag)) {
        run->drivers[interface] = std::move(*c);
      }
    }
  }
  for (const auto& [role, spec] : run->mission.services) {
    if (auto c =
            check_instance(*run->registry, spec, host::Family::service, role, robot_file, diag)) {
      run->services[role] = std::move(*c);
    }
  }
  // With the services known, every key a state reads must have a writer before it.
  if (run->machine) {
    std::vector<host::KeyUse> service_writes;
    for (const auto& [role, choice] : run->services) {
      if (const host::KindInfo* kind = run->registry->find(choice.kind)) {
        for (const host::KeyUse& k : kind->keys) {
          if (k.access == host::KeyAccess::write) service_writes.push_back(k);
        }
      }
    }
    check_machine_data(*run->machine, *run->catalog, service_writes, diag);
  }

  try {
    run->map = navigation::load_occupancy_grid(run->mission.map);
  } catch (const std::exception& e) {
    diag.error(run->mission.mark_of("map"), "map", e.what());
  }
  if (run->map)
    report_map_problems(run->mission, navigation::check_mission_on_map(run->mission, *run->map),
                        diag);
  // Every model and content file opened, and the geometry checked, before validate says ok and
  // before a run moves anything (both come through here).
  check_run_assets(run->mission, diag);
  return diag.has_errors() ? nullptr : std::move(run);
}

}  // namespace projtour
