#pragma once
// Reading mission, robot and world files. All problems in a file are collected, not only the
// first; relative paths resolve against the file that names them; files named (models, maps,
// content) must exist and be readable.
#include <filesystem>
#include <optional>

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>
#include <vector>

#include "projtour/contract/mission.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour/host/world.hpp"

namespace projtour::host {

// A kind to instantiate with its (not yet schema-checked) parameters, and where it was written.
struct PluginInstanceSpec {
  std::string kind;
  YAML::Node params;  // mapping or undefined; checked against the kind's schema by the executor
  std::string params_path;  // field path of params, for diagnostics ("drivers.base.params")
  SourceMark mark;
};

// The robot file: the view plugins get (RobotSpec) and the kinds that run it.
struct LoadedRobot : RobotSpec {
  // Hardware drivers by interface: "base", "laser", "pan_tilt", "depth_camera", "projector",
  // "colour_camera".
  std::map<std::string, PluginInstanceSpec> drivers;
  // Tour-long services by role, e.g. "localization".
  std::map<std::string, PluginInstanceSpec> services;
};

// Where the state machine comes from: the built-in default, or YAML (inline or a file).
struct MachineSource {
  bool is_default = true;
  YAML::Node node;   // the machine mapping when not default
  std::string file;  // the file the node came from
  std::string path;  // its field path ("machine" inline, "" when a file of its own)
};

// A time of day, [begin_s, end_s) in seconds after local midnight ("11:30-14:00").
struct TimeWindow {
  int begin_s = 0;
  int end_s = 0;
};

// What a target's visits show and when (mission `content:` list, `rotate:`, `hours:`).
struct TargetTimes {
  // The content list in the order written; the single form is a list of one. TargetSpec's
  // content is its first item.
  std::vector<std::filesystem::path> content;
  bool per_round = false;         // rotate: per_round (item (round - 1) mod N), else per_visit
  std::vector<TimeWindow> hours;  // empty: any time
};

// The mission's `schedule:` (README "All day"). Without one the tour is one pass, unnumbered.
struct MissionSchedule {
  bool written = false;  // rounds are numbered in the report, events and checkpoint
  std::optional<long long> rounds;
  std::optional<int> until_s;  // no round after the first begins at or after it
  int start_s = 9 * 3600;      // a dry run's time of day at mission time 0
  double pause_s = 0.0;        // between rounds, the robot where it is
};

// The mission file: the view plugins get (MissionSpec, robot included) and what only the host
// uses. Plugins are handed the MissionSpec base, so none of this reaches them.
struct LoadedMission : MissionSpec {
  MachineSource machine;
  // The robot file's driver and service choices (LoadedRobot's).
  std::map<std::string, PluginInstanceSpec> drivers;
  std::map<std::string, PluginInstanceSpec> services;
  // Where each field was written, by field path ("start", "targets[2].pose", ...), so checks
  // made after loading (map, reachability, plugins) can point at the line.
  std::map<std::string, SourceMark> marks;
  MissionSchedule schedule;
  std::vector<TargetTimes> target_times;  // by target index, one per target

  // The field's mark, or the file as a whole when it was not written.
  SourceMark mark_of(const std::string& field_path) const;
};

// nullopt when any error was recorded.
std::optional<LoadedMission> load_mission(const std::filesystem::path& file, Diagnostics& diag);
std::optional<LoadedRobot> load_robot(const std::filesystem::path& file, Diagnostics& diag);
std::optional<WorldSpec> load_world(const std::filesystem::path& file, const MissionSpec& mission,
                                    Diagnostics& diag);
// From text (the fuzzer and tests): `file_name` only labels diagnostics and anchors paths.
std::optional<LoadedMission> load_mission_from_string(const std::string& text,
                                                      const std::filesystem::path& file_name,
                                                      Diagnostics& diag);

// Throwing forms: InputError carrying every diagnostic.
LoadedMission load_mission_or_throw(const std::filesystem::path& file);

}  // namespace projtour::host
