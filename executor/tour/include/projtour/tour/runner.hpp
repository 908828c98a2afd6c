#pragma once
// The `projtour run | validate | graph` pipeline: load the mission (and world), load the
// plugins, check the machine and every parameter, check the mission against the map; only then
// create drivers, services and behaviours and tick the tour.
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/host/diagnostics.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/machine/catalog.hpp"
#include "projtour/machine/machine.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace projtour {

struct RunOptions {
  std::filesystem::path mission;
  bool dry_run = false;
  // A dry run whose base and laser are the robot's ros2_* drivers, over DDS, against
  // projtour-sim-ros2 running the same mission, world and seed (the other drivers stay simulated
  // here, following the bridge's true base pose).
  bool ros2_bridge = false;
  std::optional<std::filesystem::path> world;
  std::optional<std::uint64_t> seed;
  std::optional<std::filesystem::path> out;  // default runs/<mission>-<time>/
  bool resume = false;
  // Mission seconds per wall second; 0 = as fast as possible. Default: 0 in a dry run, else 1.
  std::optional<double> speed;
  std::vector<std::filesystem::path> plugin_paths;
  // Loads plugins from directories and libraries others may write (PluginLoadOptions).
  bool allow_writable_plugin_path = false;
  double tick_hz = 20.0;
  double cancel_grace_s = 2.0;
  // Wall-clock limit for one tick of a state without timeout_s (states with one use it).
  double watchdog_s = 30.0;
  // The live monitor (monitor.hpp): "[HOST:]PORT" to serve it; unset, off in a dry run and on
  // 127.0.0.1:8470 on hardware unless no_monitor. The control token is read from
  // monitor_token_file when given (required to bind anything but loopback), else made up.
  std::optional<std::string> monitor;
  bool no_monitor = false;
  std::optional<std::filesystem::path> monitor_token_file;
  // The proof-of-play history (history.hpp): this database, else default_history_path(); none
  // with no_history.
  std::optional<std::filesystem::path> history;
  bool no_history = false;
};

// A kind with its checked parameters.
struct InstanceChoice {
  std::string kind;
  Params params;
};

// Everything checked before anything moves.
struct PreparedRun {
  host::LoadedMission mission;
  std::optional<host::WorldSpec> world;
  std::unique_ptr<host::PluginRegistry> registry;
  std::unique_ptr<RegistryCatalog> catalog;
  std::optional<Machine> machine;
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  std::map<std::string, InstanceChoice> drivers;   // by interface
  std::map<std::string, InstanceChoice> services;  // by role
  std::vector<std::string> plugin_load_problems;
};

enum class PrepareDepth { machine, everything };

// nullptr when any error was recorded in `diag`. `depth` machine stops after the machine
// (graph); everything adds drivers, services and the map.
// Each way the mission does not fit its map, as a diagnostic at the line of the field it
// concerns (or of the field it falls back on when that one was not written).
void report_map_problems(const host::LoadedMission& mission,
                         const std::vector<navigation::MapProblem>& problems,
                         host::Diagnostics& diag);

std::unique_ptr<PreparedRun> prepare_run(const RunOptions& options, PrepareDepth depth,
                                         host::Diagnostics& diag);

// The subcommands; each returns the process exit status.
int run_command(const RunOptions& options, std::ostream& out, std::ostream& err);
int validate_command(const RunOptions& options, std::ostream& out, std::ostream& err);
int graph_command(const RunOptions& options, std::ostream& out, std::ostream& err);

}  // namespace projtour
