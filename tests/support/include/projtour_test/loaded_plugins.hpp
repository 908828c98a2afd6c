#pragma once
// One plugin registry per test program, with the named plugins loaded from the build the way the
// executor loads them; they stay loaded for the whole program, as in a run. Header-only: the
// including test's PROJTOUR_PLUGIN_BUILD_DIR names the build's plugin directory.
#include <filesystem>
#include <initializer_list>
#include <map>
#include <string>

#include "projtour/contract/params.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"

namespace projtour::test {

// The first call's names are loaded; later calls get the same registry.
inline host::PluginRegistry& loaded_plugins(std::initializer_list<const char*> names) {
  static host::PluginRegistry* registry = [names] {
    auto* r = new host::PluginRegistry;
    for (const char* name : names) {
      r->load_library(std::filesystem::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                      ("libprojtour_" + std::string(name) + ".so"));
    }
    return r;
  }();
  return *registry;
}

// A kind's default parameters with `values` set over them.
inline Params params_with(const host::PluginRegistry& registry, const std::string& kind,
                          const std::map<std::string, ParamValue>& values = {}) {
  Params p = host::default_params(registry.require(kind).params);
  for (const auto& [name, value] : values) p.set(name, value);
  return p;
}

}  // namespace projtour::test
