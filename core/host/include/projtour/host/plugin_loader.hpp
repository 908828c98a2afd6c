#pragma once
// Loading plugin shared objects (dlopen, RTLD_NOW | RTLD_LOCAL) and making objects of their
// kinds. A library stays loaded while any object made from it lives.
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/contract/plugin_abi.h"

namespace projtour::host {

// Anything wrong with a plugin; the message names the file (and the kind where there is one).
class PluginError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PluginLibrary;  // an open dlopen handle

struct PluginLoadOptions {
  // Loads from directories and libraries that others than their owner and root may write
  // (group- or world-writable, or owned by another user): --allow-writable-plugin-path. Off,
  // such a path is refused before anything in it is opened with dlopen.
  bool allow_writable_paths = false;
};

enum class Family { behaviour, driver, service };
const char* to_string(Family family);

enum class KeyAccess { read, read_if_present, write };
const char* to_string(KeyAccess access);

// One blackboard key a kind declares (plugin_abi.h projtour_key_desc).
struct KeyUse {
  std::string name;
  std::string type;
  KeyAccess access = KeyAccess::read;
};

struct KindInfo {
  std::string name;
  Family family = Family::behaviour;
  std::string interface;  // drivers: "base", ...; services: role; behaviours: ""
  std::string description;
  std::vector<ParamSpec> params;
  std::vector<std::string> outcomes;  // declared; "failed" and "cancelled" are implicit
  std::vector<KeyUse> keys;           // blackboard keys read and written
  std::string plugin_name;
  std::string plugin_version;
  std::filesystem::path library;
  const projtour_kind_desc* desc = nullptr;
  std::shared_ptr<PluginLibrary> handle;

  bool declares_outcome(const std::string& outcome) const;
};

class PluginRegistry {
 public:
  explicit PluginRegistry(PluginLoadOptions options = {});
  ~PluginRegistry();
  PluginRegistry(const PluginRegistry&) = delete;
  PluginRegistry& operator=(const PluginRegistry&) = delete;

  // The search path: each --plugin-path, then each entry of PROJTOUR_PLUGIN_PATH (':'-separated),
  // then <the directory of this library>/projtour/plugins (the same layout in a build tree and
  // an installation, so nothing is compiled in). Never the current directory unless named;
  // empty entries are skipped.
  static std::vector<std::filesystem::path> search_path(
      const std::vector<std::filesystem::path>& cli_paths);

  // Loads one shared object. Throws PluginError: the path cannot be resolved or opened (with
  // errno's text: a symlink loop is ELOOP), not a regular file, not an ELF shared object, a
  // file or a directory on its real path that others may write (unless allowed), not loadable
  // (dlerror), no entry point (not a plugin), ABI version mismatch, a malformed descriptor, or
  // a kind another plugin already provides (naming both files). Nothing of the file runs (no
  // constructor) before the checks of the path and the ELF header have passed.
  void load_library(const std::filesystem::path& file);
  // Loads every lib*.so in each directory (missing directories are skipped; one that others may
  // write is refused whole). Problems are returned as messages rather than thrown, so one bad
  // file does not hide the rest. Like PATH, a file name loaded from an earlier directory
  // shadows the same name in later ones (a build tree and an installed copy of one plugin do
  // not collide); a file that failed does not: the next directory's file of that name is
  // tried, and when it loads the failure is moved to warnings() instead.
  std::vector<std::string> load_directories(const std::vector<std::filesystem::path>& dirs);
  // Files that failed but whose name a later directory provided: harmless, worth a warning.
  const std::vector<std::string>& warnings() const { return warnings_; }

  const KindInfo* find(const std::string& kind) const;
  // Throws PluginError with "did you mean" when unknown.
  const KindInfo& require(const std::string& kind) const;
  std::vector<const KindInfo*> kinds() const;  // sorted by name

  // Each throws PluginError naming the kind and library when create fails (or throws inside),
  // or when the kind is of another family/interface.
  std::shared_ptr<Behaviour> create_behaviour(const std::string& kind, const Params& params,
                                              const RunContext& run) const;
  std::shared_ptr<Driver> create_driver(const std::string& kind, const Params& params,
                                        const RunContext& run) const;
  std::shared_ptr<Service> create_service(const std::string& kind, const Params& params,
                                          const RunContext& run) const;

  // Runs the kind's optional validate(); returns "" when fine, else the message.
  std::string validate_params(const std::string& kind, const Params& params) const;

 private:
  PluginLoadOptions options_;
  std::vector<std::string> warnings_;
  std::map<std::string, KindInfo> kinds_;
  std::map<std::string, std::shared_ptr<PluginLibrary>> libraries_;  // by canonical path
};

}  // namespace projtour::host
