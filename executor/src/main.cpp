// The projtour command: run | validate | graph | plugins | localize.
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "projtour_executor/plugin_listing.hpp"
#include "projtour_executor/runner.hpp"

#if __has_include("projtour_executor/localize_command.hpp")
#include "projtour_executor/localize_command.hpp"
#define PROJTOUR_HAS_LOCALIZE 1
#endif

namespace {

const char* const kUsage =
    "usage:\n"
    "  projtour run MISSION.yaml [--dry-run] [--world W.yaml] [--seed N] [--out DIR] [--resume]\n"
    "                            [--speed X] [--plugin-path DIR]... [--watchdog-s S]\n"
    "  projtour validate MISSION.yaml [--dry-run] [--world W.yaml] [--plugin-path DIR]...\n"
    "  projtour graph MISSION.yaml [--plugin-path DIR]...\n"
    "  projtour plugins [--plugin-path DIR]...\n"
    "  projtour localize --map M.yaml --rawlog R.rawlog --init X,Y,YAW_DEG [--out T.tum]\n"
    "exit status: 0 all projected, 3 finished with skips, 2 invalid input, 130 interrupted,\n"
    "             1 aborted by a failure\n";

struct UsageError {
  std::string message;
};

// Parses the options every mission subcommand shares; `allowed` lists the ones this
// subcommand takes.
projtour::RunOptions parse_options(int argc, char** argv, const std::vector<std::string>& allowed,
                                   std::vector<std::filesystem::path>* plugin_paths_only) {
  projtour::RunOptions options;
  bool have_mission = false;
  auto allowed_here = [&](const std::string& flag) {
    for (const auto& a : allowed) {
      if (a == flag) return true;
    }
    return false;
  };
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError{arg + " needs a value"};
      return argv[++i];
    };
    if (arg.rfind("--", 0) == 0 && !allowed_here(arg)) {
      throw UsageError{"unknown option " + arg + " for " + argv[1]};
    }
    try {
      if (arg == "--dry-run") {
        options.dry_run = true;
      } else if (arg == "--world") {
        options.world = value();
      } else if (arg == "--seed") {
        options.seed = std::stoull(value());
      } else if (arg == "--out") {
        options.out = value();
      } else if (arg == "--resume") {
        options.resume = true;
      } else if (arg == "--speed") {
        options.speed = std::stod(value());
        if (*options.speed < 0) throw UsageError{"--speed must be >= 0 (0 = as fast as possible)"};
      } else if (arg == "--watchdog-s") {
        options.watchdog_s = std::stod(value());
        if (options.watchdog_s <= 0) throw UsageError{"--watchdog-s must be > 0"};
      } else if (arg == "--plugin-path") {
        options.plugin_paths.emplace_back(value());
      } else if (arg.rfind("--", 0) != 0 && plugin_paths_only == nullptr && !have_mission) {
        options.mission = arg;
        have_mission = true;
      } else {
        throw UsageError{"unexpected argument " + arg};
      }
    } catch (const std::invalid_argument&) {
      throw UsageError{"bad number for " + arg};
    } catch (const std::out_of_range&) {
      throw UsageError{"number out of range for " + arg};
    }
  }
  if (plugin_paths_only != nullptr) {
    *plugin_paths_only = options.plugin_paths;
  } else if (!have_mission) {
    throw UsageError{std::string(argv[1]) + " needs a MISSION.yaml"};
  }
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cerr << kUsage;
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  try {
    if (command == "run") {
      const auto options = parse_options(argc, argv,
                                         {"--dry-run", "--world", "--seed", "--out", "--resume",
                                          "--speed", "--plugin-path", "--watchdog-s"},
                                         nullptr);
      return projtour::run_command(options, std::cout, std::cerr);
    }
    if (command == "validate") {
      const auto options =
          parse_options(argc, argv, {"--dry-run", "--world", "--plugin-path"}, nullptr);
      return projtour::validate_command(options, std::cout, std::cerr);
    }
    if (command == "graph") {
      const auto options = parse_options(argc, argv, {"--plugin-path"}, nullptr);
      return projtour::graph_command(options, std::cout, std::cerr);
    }
    if (command == "plugins") {
      std::vector<std::filesystem::path> paths;
      parse_options(argc, argv, {"--plugin-path"}, &paths);
      return projtour::run_plugins_command(paths, std::cout, std::cerr);
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
