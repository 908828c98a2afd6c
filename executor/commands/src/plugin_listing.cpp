#include "projtour/commands/plugin_listing.hpp"

#include <algorithm>
#include <iomanip>
#include <set>
#include <string>
#include <system_error>

namespace projtour {

namespace {

constexpr int kLabelWidth = 13;  // "description" plus two spaces

std::string shown_default(const ParamSpec& spec) {
  if (spec.type == ParamType::string) return "\"" + spec.default_value + "\"";
  return spec.required() ? "(required)" : spec.default_value;
}

void print_field(std::ostream& out, const char* label, const std::string& value) {
  out << "  " << std::left << std::setw(kLabelWidth) << label << value << "\n";
}

void print_params(std::ostream& out, const std::vector<ParamSpec>& params) {
  if (params.empty()) {
    print_field(out, "parameters", "none");
    return;
  }
  std::size_t name_w = 4;
  std::size_t type_w = 4;
  std::size_t default_w = 7;
  for (const auto& p : params) {
    name_w = std::max(name_w, p.name.size());
    type_w = std::max(type_w, std::string(to_string(p.type)).size());
    default_w = std::max(default_w, shown_default(p).size());
  }
  auto row = [&](const std::string& name, const std::string& type, const std::string& def,
                 const std::string& description) {
    std::string line = name;
    line.resize(name_w + 2, ' ');
    line += type;
    line.resize(name_w + 2 + type_w + 2, ' ');
    line += def;
    line.resize(name_w + 2 + type_w + 2 + default_w + 2, ' ');
    line += description;
    while (!line.empty() && line.back() == ' ') line.pop_back();
    return line;
  };
  print_field(out, "parameters", row("name", "type", "default", "description"));
  for (const auto& p : params) {
    print_field(out, "", row(p.name, to_string(p.type), shown_default(p), p.description));
  }
}

std::string joined(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

}  // namespace

void print_plugin_listing(const host::PluginRegistry& registry, std::ostream& out) {
  const auto kinds = registry.kinds();
  std::set<std::string> plugins;
  for (const host::KindInfo* kind : kinds) plugins.insert(kind->library.string());
  if (kinds.empty()) {
    out << "no plugin kinds found\n";
    return;
  }
  out << kinds.size() << (kinds.size() == 1 ? " kind" : " kinds") << " from " << plugins.size()
      << (plugins.size() == 1 ? " plugin" : " plugins") << "\n";
  for (const host::KindInfo* kind : kinds) {
    out << "\n" << kind->name << " (" << to_string(kind->family) << ")\n";
    print_field(out, "plugin", kind->plugin_name + " " + kind->plugin_version);
    print_field(out, "library", kind->library.string());
    if (kind->family == host::Family::driver) print_field(out, "interface", kind->interface);
    if (kind->family == host::Family::service) print_field(out, "role", kind->interface);
    print_field(out, "description", kind->description);
    print_params(out, kind->params);
    if (kind->family == host::Family::behaviour) {
      print_field(
          out, "outcomes",
          joined(kind->outcomes) + " (and " + kOutcomeFailed + ", " + kOutcomeCancelled + ")");
    }
    for (const host::KeyAccess access :
         {host::KeyAccess::read, host::KeyAccess::read_if_present, host::KeyAccess::write}) {
      std::vector<std::string> keys;
      for (const host::KeyUse& k : kind->keys) {
        if (k.access == access) keys.push_back(k.name + " (" + k.type + ")");
      }
      if (!keys.empty()) print_field(out, to_string(access), joined(keys));
    }
  }
}

int run_plugins_command(const std::vector<std::filesystem::path>& cli_paths, std::ostream& out,
                        std::ostream& err, const host::PluginLoadOptions& load_options) {
  const auto dirs = host::PluginRegistry::search_path(cli_paths);
  out << "search path:\n";
  for (const auto& dir : dirs) {
    std::error_code ec;
    out << "  " << dir.string() << (std::filesystem::is_directory(dir, ec) ? "" : " (missing)")
        << "\n";
  }
  host::PluginRegistry registry(load_options);
  const auto failures = registry.load_directories(dirs);
  out << "\n";
  print_plugin_listing(registry, out);
  for (const auto& failure : failures) err << "projtour: plugins: " << failure << "\n";
  for (const auto& replaced : registry.warnings()) {
    err << "projtour: plugins: warning: " << replaced << "\n";
  }
  return failures.empty() ? 0 : 1;
}

}  // namespace projtour
