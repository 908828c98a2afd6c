#pragma once
// `projtour plugins`: what the plugin search path provides, kind by kind.
#include <filesystem>
#include <ostream>
#include <vector>

#include "projtour/host/plugin_loader.hpp"

namespace projtour {

// For every kind (sorted by name): plugin and version, library, family, interface or role,
// description, each parameter (name, type, default, description) and the outcomes.
void print_plugin_listing(const host::PluginRegistry& registry, std::ostream& out);

// The whole subcommand: loads every plugin on PluginRegistry::search_path(cli_paths), prints
// the directories searched and the listing to `out`, and each file that failed to load to
// `err` (a broken file whose name a later directory provided as a warning). Returns the exit
// status: 0, or 1 when any file or directory failed to load.
int run_plugins_command(const std::vector<std::filesystem::path>& cli_paths, std::ostream& out,
                        std::ostream& err, const host::PluginLoadOptions& load_options = {});

}  // namespace projtour
