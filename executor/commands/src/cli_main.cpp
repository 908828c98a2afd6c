// The projtour command's module (cli_module.hpp): run | validate | graph | plugins | localize,
// and the usage. `history` is the launcher's own (main.cpp).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "cli_module.hpp"
#include "projtour/cli/options.hpp"
#include "projtour/commands/plugin_listing.hpp"
#include "projtour/tour/runner.hpp"

#if __has_include("projtour/commands/localize_command.hpp")
#include "projtour/commands/localize_command.hpp"
#define PROJTOUR_HAS_LOCALIZE 1
#endif

namespace {

const char* const kUsage =
    "usage:\n"
    "  projtour run MISSION.yaml [--dry-run [--ros2-bridge]] [--world W.yaml] [--seed N] [--out "
    "DIR] [--resume]\n"
    "                            [--speed X] [--plugin-path DIR]... [--watchdog-s S]\n"
    "                            [--monitor [HOST:]PORT | --no-monitor] [--monitor-token FILE]\n"
    "                            [--history FILE | --no-history]\n"
    "  projtour validate MISSION.yaml [--dry-run] [--world W.yaml] [--plugin-path DIR]...\n"
    "  projtour graph MISSION.yaml [--plugin-path DIR]...\n"
    "  projtour plugins [--plugin-path DIR]...\n"
    "    (each command with --plugin-path also takes --allow-writable-plugin-path: load from\n"
    "     directories and libraries that others than their owner and root may write)\n"
    "  projtour history [--history FILE] [--from T] [--to T] [--content NAME] [--target ID]\n"
    "                   [--by content|target|day|run] [--csv | --json | --html FILE]\n"
    "                   [--include-dry-runs]\n"
    "  projtour localize --map M.yaml --rawlog R.rawlog --init X,Y,YAW_DEG [--out T.tum]\n"
    "exit status: 0 all projected, 3 finished with skips, 2 invalid input, 130 interrupted,\n"
    "             1 aborted by a failure\n";

struct UsageError {
  std::string message;
};

enum Option {
  kDryRun = 1,
  kWorld = 2,
  kSeed = 4,
  kOut = 8,
  kResume = 16,
  kSpeed = 32,
  kWatchdog = 64,
  kMission = 128,
  kMonitor = 256,
  kHistory = 512
};

// Parses a mission subcommand's arguments (argv[2]...); `options` is a mask of what this
// subcommand takes, --plugin-path and --allow-writable-plugin-path always. Every option but
// --plugin-path may be given once.
projtour::RunOptions parse_options(int argc, char** argv, int options) {
  const std::string command = argv[1];
  projtour::RunOptions run;
  CLI::App app("projtour " + command, "projtour " + command);
  // kUsage is the help; CLI11's --help would only describe this one subcommand.
  app.set_help_flag();
  // Unknown arguments are collected and reported below in projtour's words.
  app.allow_extras();
  std::string mission;
  if (options & kMission) app.add_option("mission", mission, "MISSION.yaml");
  if (options & kDryRun) app.add_flag("--dry-run", run.dry_run);
  if (options & kDryRun) app.add_flag("--ros2-bridge", run.ros2_bridge);
  if (options & kWorld) {
    app.add_option_function<std::string>("--world", [&](const std::string& w) { run.world = w; })
        ->type_name("W.yaml");
  }
  if (options & kSeed) {
    projtour::cli::add_uint64(
        app, "--seed", [&](std::uint64_t s) { run.seed = s; }, "N");
  }
  if (options & kOut) {
    app.add_option_function<std::string>("--out", [&](const std::string& o) { run.out = o; })
        ->type_name("DIR");
  }
  if (options & kResume) app.add_flag("--resume", run.resume);
  if (options & kSpeed) {
    projtour::cli::add_finite(
        app, "--speed", [&](double x) { run.speed = x; },
        [](double x) {
          return x > 0 ? "" : "must be > 0 (a dry run without --speed runs as fast as it can)";
        },
        "X");
  }
  if (options & kWatchdog) {
    projtour::cli::add_finite(
        app, "--watchdog-s", [&](double s) { run.watchdog_s = s; },
        [](double s) { return s <= 0 ? "must be > 0" : ""; }, "S");
  }
  if (options & kMonitor) {
    app.add_option_function<std::string>("--monitor",
                                         [&](const std::string& a) { run.monitor = a; })
        ->type_name("[HOST:]PORT");
    app.add_flag("--no-monitor", run.no_monitor);
    app.add_option_function<std::string>("--monitor-token",
                                         [&](const std::string& f) { run.monitor_token_file = f; })
        ->type_name("FILE");
  }
  if (options & kHistory) {
    app.add_option_function<std::string>("--history",
                                         [&](const std::string& f) { run.history = f; })
        ->type_name("FILE");
    app.add_flag("--no-history", run.no_history);
  }
  std::vector<std::string> plugin_paths;
  app.add_option("--plugin-path", plugin_paths)->type_name("DIR")->allow_extra_args(false);
  app.add_flag("--allow-writable-plugin-path", run.allow_writable_plugin_path);
  for (CLI::Option* option : app.get_options()) {
    if (option->get_name() != "--plugin-path") {
      option->multi_option_policy(CLI::MultiOptionPolicy::Throw);
    }
  }
  try {
    app.parse(argc - 1, argv + 1);
  } catch (const CLI::ParseError& e) {
    throw UsageError{e.what()};
  }
  for (const std::string& extra : app.remaining()) {
    if (extra.rfind("-", 0) == 0) throw UsageError{"unknown option " + extra + " for " + command};
    throw UsageError{"unexpected argument " + extra};
  }
  if ((options & kMission) && mission.empty()) {
    throw UsageError{command + " needs a MISSION.yaml"};
  }
  run.mission = mission;
  run.plugin_paths.assign(plugin_paths.begin(), plugin_paths.end());
  return run;
}

}  // namespace

int projtour_cli_main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cerr << kUsage;
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  try {
    if (command == "run") {
      const auto options = parse_options(argc, argv,
                                         kMission | kDryRun | kWorld | kSeed | kOut | kResume |
                                             kSpeed | kWatchdog | kMonitor | kHistory);
      return projtour::run_command(options, std::cout, std::cerr);
    }
    if (command == "validate") {
      const auto options = parse_options(argc, argv, kMission | kDryRun | kWorld);
      return projtour::validate_command(options, std::cout, std::cerr);
    }
    if (command == "graph") {
      const auto options = parse_options(argc, argv, kMission);
      return projtour::graph_command(options, std::cout, std::cerr);
    }
    if (command == "plugins") {
      const auto options = parse_options(argc, argv, 0);
      return projtour::run_plugins_command(
          options.plugin_paths, std::cout, std::cerr,
          projtour::host::PluginLoadOptions{options.allow_writable_plugin_path});
    }
    if (command == "localize") {
#ifdef PROJTOUR_HAS_LOCALIZE
      return projtour::run_localize_command(argc - 1, argv + 1);
#else
      std::cerr << "projtour: localize is not built in this tree\n";
      return 2;
#endif
    }
  } catch (const UsageError& e) {
    std::cerr << "projtour: " << e.message << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "projtour: " << e.what() << "\n";
    return 1;
  }
  std::cerr << "projtour: unknown command \"" << command << "\"\n" << kUsage;
  return 2;
}
