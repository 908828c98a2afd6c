#include "projtour/host/plugin_loader.hpp"

#include <dlfcn.h>
#include <elf.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <system_error>
#include <type_traits>
#include <utility>

#include "projtour/host/diagnostics.hpp"
#include "projtour/host/yaml_reader.hpp"

namespace fs = std::filesystem;

namespace projtour::host {

// Owns one dlopen handle; the last shared_ptr to it (the registry's, or one held by an object's
// deleter) closes the library.
class PluginLibrary {
 public:
  PluginLibrary(void* handle, fs::path file) : handle_(handle), file_(std::move(file)) {}
  ~PluginLibrary() { dlclose(handle_); }
  PluginLibrary(const PluginLibrary&) = delete;
  PluginLibrary& operator=(const PluginLibrary&) = delete;

  void* handle() const { return handle_; }
  const fs::path& file() const { return file_; }

 private:
  void* handle_;
  fs::path file_;
};

const char* to_string(Family family) {
  switch (family) {
    case Family::behaviour:
      return "behaviour";
    case Family::driver:
      return "driver";
    case Family::service:
      return "service";
  }
  return "?";
}

const char* to_string(KeyAccess access) {
  switch (access) {
    case KeyAccess::read:
      return "reads";
    case KeyAccess::read_if_present:
      return "may read";
    case KeyAccess::write:
      return "writes";
  }
  return "?";
}

bool KindInfo::declares_outcome(const std::string& outcome) const {
  return std::find(outcomes.begin(), outcomes.end(), outcome) != outcomes.end();
}

PluginRegistry::PluginRegistry(PluginLoadOptions options) : options_(options) {}
PluginRegistry::~PluginRegistry() = default;

namespace {

constexpr std::array<const char*, 6> kDriverInterfaces = {
    "base", "laser", "pan_tilt", "depth_camera", "projector", "colour_camera"};

std::string in_quotes(const std::string& text) {
  return "\"" + text + "\"";
}

[[noreturn]] void fail(const fs::path& file, const std::string& reason) {
  throw PluginError(file.string() + ": " + reason);
}

std::string last_dlerror(const char* fallback) {
  const char* message = dlerror();
  return message != nullptr ? message : fallback;
}

std::string errno_text(int error) {
  return std::error_code(error, std::generic_category()).message();
}

std::string mode_text(mode_t mode) {
  std::array<char, 8> text{};
  std::snprintf(text.data(), text.size(), "%04o", static_cast<unsigned>(mode & 07777));
  return text.data();
}

constexpr const char* kTrustRule =
    "; a plugin path must be writable by its owner and root only "
    "(--allow-writable-plugin-path loads it anyway)";

// Why someone other than root and this process's user could change what `st` describes; ""
// when nobody could. `sticky_is_enough`: for a directory above a plugin path, a sticky bit
// (as on /tmp) keeps others from renaming or replacing the entries they do not own.
std::string writable_by_others(const struct stat& st, bool sticky_is_enough) {
  const uid_t me = ::geteuid();
  if (st.st_uid != 0 && st.st_uid != me) {
    return "owned by uid " + std::to_string(st.st_uid) + " (mode " + mode_text(st.st_mode) +
           "), neither root nor this user (uid " + std::to_string(me) + ")";
  }
  if (sticky_is_enough && (st.st_mode & S_ISVTX) != 0) return "";
  if ((st.st_mode & S_IWOTH) != 0) return "world-writable (mode " + mode_text(st.st_mode) + ")";
  if ((st.st_mode & S_IWGRP) != 0) return "group-writable (mode " + mode_text(st.st_mode) + ")";
  return "";
}

// "" when only root and this user can write the directory `dir` (canonical) and every
// directory above it; else why not, to follow the directory's name. The directories above
// count because whoever may rename one of them may put another tree in its place after the
// check and before dlopen.
std::string untrusted_directory(const fs::path& dir) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) return "cannot be checked: " + errno_text(errno);
  if (std::string why = writable_by_others(st, false); !why.empty()) return "is " + why;
  for (fs::path up = dir; up.has_relative_path();) {
    up = up.parent_path();
    if (::stat(up.c_str(), &st) != 0) {
      return "cannot be checked: " + up.string() + ": " + errno_text(errno);
    }
    if (std::string why = writable_by_others(st, true); !why.empty()) {
      return "is under " + up.string() + ", which is " + why;
    }
  }
  return "";
}

// Reads exactly `size` bytes at `offset`; false on a short read (errno 0) or an error.
bool read_at(int fd, void* out, std::size_t size, off_t offset) {
  errno = 0;
  return ::pread(fd, out, size, offset) == static_cast<ssize_t>(size);
}

// "" when `file` opens and is an ELF shared object whose loadable segments lie within it; else
// why not (the real errno when it cannot be opened or read). Checked here rather than left to
// dlopen: nothing of a file that is not one gets mapped, the reason is plain, and a truncated
// library, which glibc maps past its end and then touches, would kill the process with SIGBUS.
std::string not_a_shared_object(const fs::path& file) {
  // O_NOFOLLOW: `file` is canonical, so a symlink found now was planted after the check.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) return "cannot open: " + errno_text(errno);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) return "cannot open: " + errno_text(errno);
  std::array<unsigned char, EI_NIDENT + 2> ident{};  // e_ident, then e_type
  if (!read_at(fd, ident.data(), ident.size(), 0)) {
    if (errno != 0) return "cannot read: " + errno_text(errno);
    return "not an ELF shared object (no ELF header)";
  }
  if (std::memcmp(ident.data(), ELFMAG, SELFMAG) != 0) {
    return "not an ELF shared object (no ELF header)";
  }
  const unsigned low = ident[EI_NIDENT];
  const unsigned high = ident[EI_NIDENT + 1];
  const unsigned type = ident[EI_DATA] == ELFDATA2MSB ? (low << 8U) | high : (high << 8U) | low;
  if (type != ET_DYN) {
    return "not an ELF shared object (ELF type " + std::to_string(type) + ", a shared object is " +
           std::to_string(ET_DYN) + ")";
  }
  // Another class or byte order cannot be loaded here: dlopen's own words say which.
  constexpr unsigned char kNativeClass = sizeof(void*) == 8 ? ELFCLASS64 : ELFCLASS32;
  constexpr unsigned char kNativeData =
      __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? ELFDATA2LSB : ELFDATA2MSB;
  if (ident[EI_CLASS] != kNativeClass || ident[EI_DATA] != kNativeData) return "";
  using Ehdr = std::conditional_t<sizeof(void*) == 8, Elf64_Ehdr, Elf32_Ehdr>;
  using Phdr = std::conditional_t<sizeof(void*) == 8, Elf64_Phdr, Elf32_Phdr>;
  const auto size = static_cast<std::uint64_t>(st.st_size);
  Ehdr header{};
  if (!read_at(fd, &header, sizeof header, 0))
    return "truncated ELF shared object (no full header)";
  if (header.e_phentsize != sizeof(Phdr)) {
    return "not an ELF shared object (program header entries of " +
           std::to_string(header.e_phentsize) + " bytes)";
  }
  for (unsigned i = 0; i < header.e_phnum; ++i) {
    Phdr segment{};
    const std::uint64_t at = header.e_phoff + std::uint64_t{i} * sizeof(Phdr);
    if (at + sizeof(Phdr) > size ||
        !read_at(fd, &segment, sizeof segment, static_cast<off_t>(at))) {
      return "truncated ELF shared object (program header " + std::to_string(i) +
             " past the end of the file, " + std::to_string(size) + " bytes)";
    }
    const std::uint64_t end = std::uint64_t{segment.p_offset} + segment.p_filesz;
    if (segment.p_type == PT_LOAD && end > size) {
      return "truncated ELF shared object (segment " + std::to_string(i) + " ends at byte " +
             std::to_string(end) + ", the file has " + std::to_string(size) + ")";
    }
  }
  return "";
}

// The directory of the shared object this code is in: an installed host that was moved (or
// installed with `cmake --install --prefix`) still finds the plugins installed beside it.
fs::path core_library_dir() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&core_library_dir), &info) == 0 || info.dli_fname == nullptr) {
    return {};
  }
  std::error_code ec;
  const fs::path file = fs::canonical(info.dli_fname, ec);
  return ec ? fs::path() : file.parent_path();
}

// True when `text` reads as a value of `type` (the same reading Params applies to missions).
bool default_parses(const std::string& text, ParamType type) {
  Diagnostics scratch;
  const auto node = load_yaml_string(text, "<default>", scratch);
  if (!node) return false;
  const YamlField field(*node, "<default>", scratch);
  switch (type) {
    case ParamType::number:
      return field.as_double().has_value();
    case ParamType::integer:
      return field.as_int().has_value();
    case ParamType::boolean:
      return field.as_bool().has_value();
    case ParamType::string:
      return true;
  }
  return false;
}

ParamSpec read_param(const fs::path& file, const std::string& where, const projtour_param_desc& d,
                     std::size_t index) {
  const std::string at = where + "parameter " + std::to_string(index);
  if (d.name == nullptr || d.name[0] == '\0') fail(file, at + ": null or empty name");
  ParamSpec spec;
  spec.name = d.name;
  const std::string named = where + "parameter " + in_quotes(spec.name);
  if (d.type == nullptr) fail(file, named + ": null type");
  if (!param_type_from_string(d.type, spec.type)) {
    fail(file, named + ": unknown type " + in_quotes(d.type) +
                   " (expected number, integer, boolean or string)");
  }
  spec.default_value = d.default_value != nullptr ? d.default_value : "";
  spec.description = d.description != nullptr ? d.description : "";
  if (!spec.default_value.empty() && !default_parses(spec.default_value, spec.type)) {
    fail(file, named + ": default " + in_quotes(spec.default_value) + " is not a " +
                   to_string(spec.type));
  }
  return spec;
}

KindInfo read_kind(const fs::path& file, const projtour_kind_desc& d, std::size_t index) {
  if (d.name == nullptr || d.name[0] == '\0') {
    fail(file, "kind " + std::to_string(index) + ": null or empty name");
  }
  KindInfo kind;
  kind.name = d.name;
  const std::string where = "kind " + in_quotes(kind.name) + ": ";
  switch (d.family) {
    case PROJTOUR_FAMILY_BEHAVIOUR:
      kind.family = Family::behaviour;
      break;
    case PROJTOUR_FAMILY_DRIVER:
      kind.family = Family::driver;
      break;
    case PROJTOUR_FAMILY_SERVICE:
      kind.family = Family::service;
      break;
    default:
      fail(file, where + "unknown family " + std::to_string(d.family) +
                     " (expected 1 behaviour, 2 driver or 3 service)");
  }
  kind.interface = d.interface != nullptr ? d.interface : "";
  switch (kind.family) {
    case Family::behaviour:
      if (!kind.interface.empty()) {
        fail(file, where + "a behaviour has no interface, got " + in_quotes(kind.interface));
      }
      if (d.outcome_count == 0) fail(file, where + "a behaviour declares no outcomes");
      break;
    case Family::driver:
      if (std::find(kDriverInterfaces.begin(), kDriverInterfaces.end(), kind.interface) ==
          kDriverInterfaces.end()) {
        fail(file,
             where + "driver interface " + in_quotes(kind.interface) +
                 " is not one of base, laser, pan_tilt, depth_camera, projector, colour_camera");
      }
      break;
    case Family::service:
      if (kind.interface.empty()) fail(file, where + "a service names no role");
      break;
  }
  kind.description = d.description != nullptr ? d.description : "";

  if (d.param_count > 0 && d.params == nullptr) {
    fail(file, where + "param_count is " + std::to_string(d.param_count) + " but params is null");
  }
  for (std::uint32_t i = 0; i < d.param_count; ++i) {
    ParamSpec spec = read_param(file, where, d.params[i], i);
    for (const auto& other : kind.params) {
      if (other.name == spec.name)
        fail(file, where + "parameter " + in_quotes(spec.name) + " twice");
    }
    kind.params.push_back(std::move(spec));
  }

  if (d.outcome_count > 0 && d.outcomes == nullptr) {
    fail(file,
         where + "outcome_count is " + std::to_string(d.outcome_count) + " but outcomes is null");
  }
  for (std::uint32_t i = 0; i < d.outcome_count; ++i) {
    if (d.outcomes[i] == nullptr || d.outcomes[i][0] == '\0') {
      fail(file, where + "outcome " + std::to_string(i) + ": null or empty");
    }
    if (kind.declares_outcome(d.outcomes[i])) {
      fail(file, where + "outcome " + in_quotes(d.outcomes[i]) + " twice");
    }
    kind.outcomes.emplace_back(d.outcomes[i]);
  }

  if (d.key_count > 0 && d.keys == nullptr) {
    fail(file, where + "key_count is " + std::to_string(d.key_count) + " but keys is null");
  }
  for (std::uint32_t i = 0; i < d.key_count; ++i) {
    const projtour_key_desc& k = d.keys[i];
    const std::string at = where + "key " + std::to_string(i);
    if (k.name == nullptr || k.name[0] == '\0') fail(file, at + ": null or empty name");
    if (k.type == nullptr || k.type[0] == '\0') {
      fail(file, where + "key " + in_quotes(k.name) + ": null or empty type");
    }
    KeyUse use;
    use.name = k.name;
    use.type = k.type;
    switch (k.access) {
      case PROJTOUR_KEY_READ:
        use.access = KeyAccess::read;
        break;
      case PROJTOUR_KEY_READ_OPTIONAL:
        use.access = KeyAccess::read_if_present;
        break;
      case PROJTOUR_KEY_WRITE:
        use.access = KeyAccess::write;
        break;
      default:
        fail(file, where + "key " + in_quotes(use.name) + ": unknown access " +
                       std::to_string(k.access) +
                       " (expected 1 read, 2 read if present or 3 write)");
    }
    for (const auto& other : kind.keys) {
      if (other.name == use.name && other.access == use.access) {
        fail(file, where + "key " + in_quotes(use.name) + " twice");
      }
      if (other.name == use.name && other.type != use.type) {
        fail(file, where + "key " + in_quotes(use.name) + " as " + in_quotes(other.type) +
                       " and as " + in_quotes(use.type));
      }
    }
    kind.keys.push_back(std::move(use));
  }

  if (d.create == nullptr) fail(file, where + "null create function");
  if (d.destroy == nullptr) fail(file, where + "null destroy function");
  kind.desc = &d;
  return kind;
}

// Whether a created driver really implements the interface its kind declares.
bool implements(const Driver& driver, const std::string& interface) {
  if (interface == "base") return dynamic_cast<const BaseDriver*>(&driver) != nullptr;
  if (interface == "laser") return dynamic_cast<const LaserDriver*>(&driver) != nullptr;
  if (interface == "pan_tilt") return dynamic_cast<const PanTiltDriver*>(&driver) != nullptr;
  if (interface == "depth_camera") {
    return dynamic_cast<const DepthCameraDriver*>(&driver) != nullptr;
  }
  if (interface == "projector") return dynamic_cast<const ProjectorDriver*>(&driver) != nullptr;
  if (interface == "colour_camera") {
    return dynamic_cast<const ColourCameraDriver*>(&driver) != nullptr;
  }
  return false;
}

std::string kind_prefix(const KindInfo& kind) {
  return kind.library.string() + ": kind " + in_quotes(kind.name) + ": ";
}

// Calls the kind's create() and wraps the object so that destroying it calls the kind's
// destroy() while the library is still loaded (the deleter holds the library).
template <typename Base>
std::shared_ptr<Base> make_object(const KindInfo& kind, Family family, const Params& params,
                                  const RunContext& run) {
  if (kind.family != family) {
    throw PluginError(kind_prefix(kind) + "is a " + to_string(kind.family) + ", not a " +
                      to_string(family));
  }
  std::array<char, 1024> error{};
  void* raw = nullptr;
  try {
    raw = kind.desc->create(&params, &run, error.data(), error.size());
  } catch (const std::exception& e) {
    // A hand-written create() without projtour::plugin_detail's guard may let one through.
    throw PluginError(kind_prefix(kind) + "create failed: " + e.what());
  }
  if (raw == nullptr) {
    const std::string why = error[0] != '\0' ? error.data() : "create returned null";
    throw PluginError(kind_prefix(kind) + "create failed: " + why);
  }
  const projtour_destroy_fn destroy = kind.desc->destroy;
  std::shared_ptr<PluginLibrary> library = kind.handle;
  return std::shared_ptr<Base>(static_cast<Base*>(raw),
                               [destroy, library](Base* object) { destroy(object); });
}

}  // namespace

std::vector<fs::path> PluginRegistry::search_path(const std::vector<fs::path>& cli_paths) {
  std::vector<fs::path> dirs;
  auto add = [&dirs](const fs::path& dir) {
    // An empty entry is skipped: it must not mean the current directory.
    if (dir.empty()) return;
    const fs::path normal = dir.lexically_normal();
    if (std::find(dirs.begin(), dirs.end(), normal) == dirs.end()) dirs.push_back(normal);
  };
  for (const auto& dir : cli_paths) add(dir);
  if (const char* env = std::getenv("PROJTOUR_PLUGIN_PATH")) {
    const std::string text = env;
    std::size_t begin = 0;
    while (begin <= text.size()) {
      const std::size_t end = std::min(text.find(':', begin), text.size());
      add(fs::path(text.substr(begin, end - begin)));
      begin = end + 1;
    }
  }
  // Nothing compiled in: a build tree and an installation both keep their plugins in
  // <libdir>/projtour/plugins beside this library, so an installed host never looks in the tree
  // it was built in.
  const fs::path core_dir = core_library_dir();
  std::error_code ec;
  if (!core_dir.empty() && fs::is_directory(core_dir / "projtour" / "plugins", ec)) {
    add(core_dir / "projtour" / "plugins");
  }
  return dirs;
}

void PluginRegistry::load_library(const fs::path& file) {
  std::error_code ec;
  // Resolved first, not tested with exists(): that reads a symlink loop (ELOOP) as a missing
  // file. Everything below looks at the real file, the one dlopen will map.
  const fs::path canonical = fs::canonical(file, ec);
  if (ec) fail(file, "cannot open: " + ec.message());
  if (libraries_.count(canonical.string()) != 0) return;  // already loaded: nothing new

  struct stat st {};
  if (::stat(canonical.c_str(), &st) != 0) fail(file, "cannot open: " + errno_text(errno));
  if (!S_ISREG(st.st_mode)) fail(file, "not a regular file");
  // dlopen runs the library's constructors: whatever it is must be known to come from a
  // trusted writer before then.
  if (!options_.allow_writable_paths) {
    const bool named_as_is = fs::absolute(file).lexically_normal() == canonical;
    const std::string subject =
        named_as_is ? "plugin library" : "plugin library " + canonical.string();
    if (const std::string why = writable_by_others(st, false); !why.empty()) {
      fail(file, subject + " is " + why + kTrustRule);
    }
    const fs::path dir = canonical.parent_path();
    if (const std::string why = untrusted_directory(dir); !why.empty()) {
      fail(file, "its directory " + dir.string() + " " + why + kTrustRule);
    }
  }
  if (const std::string why = not_a_shared_object(canonical); !why.empty()) fail(file, why);

  dlerror();
  // RTLD_NODELETE: values a plugin leaves behind (std::any on the blackboard, exception objects,
  // static destructors) carry code from its library; unmapping it while those may still run
  // would crash at teardown, so dlclose only drops the reference.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (handle == nullptr) fail(file, "cannot load: " + last_dlerror("dlopen failed"));
  auto library = std::make_shared<PluginLibrary>(handle, canonical);

  dlerror();
  void* entry = dlsym(handle, PROJTOUR_ENTRY_POINT);
  if (entry == nullptr) {
    fail(file, "not a projtour plugin (no " PROJTOUR_ENTRY_POINT ")");
  }
  const auto* desc = reinterpret_cast<projtour_entry_fn>(entry)();
  if (desc == nullptr) fail(file, PROJTOUR_ENTRY_POINT " returned null");
  // Nothing else of the descriptor is read before this: another ABI may lay it out differently.
  if (desc->abi_version != PROJTOUR_ABI_VERSION) {
    fail(file, "ABI version " + std::to_string(desc->abi_version) + ", this projtour needs " +
                   std::to_string(PROJTOUR_ABI_VERSION));
  }
  if (desc->name == nullptr || desc->name[0] == '\0') fail(file, "null or empty plugin name");
  if (desc->version == nullptr || desc->version[0] == '\0') {
    fail(file, "plugin " + in_quotes(desc->name) + ": null or empty version");
  }
  if (desc->kind_count == 0 || desc->kinds == nullptr) {
    fail(file, "plugin " + in_quotes(desc->name) + " provides no kinds");
  }

  std::vector<KindInfo> kinds;
  for (std::uint32_t i = 0; i < desc->kind_count; ++i) {
    KindInfo kind = read_kind(file, desc->kinds[i], i);
    for (const auto& other : kinds) {
      if (other.name == kind.name) fail(file, "kind " + in_quotes(kind.name) + " twice");
    }
    const auto existing = kinds_.find(kind.name);
    if (existing != kinds_.end()) {
      fail(file, "kind " + in_quotes(kind.name) + " is already provided by " +
                     existing->second.library.string() + " (plugin " +
                     in_quotes(existing->second.plugin_name) + ")");
    }
    kind.plugin_name = desc->name;
    kind.plugin_version = desc->version;
    kind.library = canonical;
    kind.handle = library;
    kinds.push_back(std::move(kind));
  }
  // Only a fully valid library registers anything.
  for (auto& kind : kinds) {
    const std::string name = kind.name;
    kinds_.emplace(name, std::move(kind));
  }
  libraries_.emplace(canonical.string(), std::move(library));
}

std::vector<std::string> PluginRegistry::load_directories(const std::vector<fs::path>& dirs) {
  // Like PATH, a file name loaded from an earlier directory shadows the same name in later ones,
  // so a build tree and an installed copy of the same plugin do not collide. A file that failed
  // shadows nothing: a broken copy must not hide a good one further down.
  std::set<std::string> loaded_names;
  for (const auto& [path, library] : libraries_)
    loaded_names.insert(fs::path(path).filename().string());
  // Every problem in path order, with the file name it is about ("" for a directory's).
  std::vector<std::pair<std::string, std::string>> problems;
  std::map<std::string, fs::path> loaded_from;  // file name -> the file that loaded
  for (const auto& dir : dirs) {
    if (dir.empty()) continue;
    struct stat st {};
    if (::stat(dir.c_str(), &st) != 0) {
      const int error = errno;
      // A missing entry is skipped like a missing PATH entry; anything else is worth saying.
      if (error == ENOENT || error == ENOTDIR) continue;
      problems.emplace_back("", dir.string() + ": cannot open directory: " + errno_text(error));
      continue;
    }
    if (!S_ISDIR(st.st_mode)) {
      problems.emplace_back("", dir.string() + ": not a directory");
      continue;
    }
    std::error_code ec;
    if (!options_.allow_writable_paths) {
      // Whoever may write the directory may add a lib*.so to it: refused before it is listed.
      const fs::path real = fs::canonical(dir, ec);
      const std::string why = ec ? "cannot be checked: " + ec.message() : untrusted_directory(real);
      if (!why.empty()) {
        problems.emplace_back("", dir.string() + ": plugin directory " + why + kTrustRule);
        continue;
      }
    }
    std::vector<fs::path> files;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name.size() > 6 && name.compare(0, 3, "lib") == 0 &&
          name.compare(name.size() - 3, 3, ".so") == 0) {
        files.push_back(it->path());
      }
    }
    if (ec) {
      problems.emplace_back("", dir.string() + ": cannot list directory: " + ec.message());
      continue;
    }
    std::sort(files.begin(), files.end());
    for (const auto& file : files) {
      const std::string name = file.filename().string();
      if (loaded_names.count(name) != 0) continue;
      try {
        load_library(file);
        loaded_names.insert(name);
        loaded_from.emplace(name, file);
      } catch (const PluginError& e) {
        problems.emplace_back(name, e.what());
      }
    }
  }
  std::vector<std::string> failures;
  for (auto& [name, message] : problems) {
    const auto good = loaded_from.find(name);
    if (good == loaded_from.end()) {
      failures.push_back(std::move(message));
    } else {
      warnings_.push_back(message + " (" + good->second.string() +
                          " further down the path was loaded instead)");
    }
  }
  return failures;
}

const KindInfo* PluginRegistry::find(const std::string& kind) const {
  const auto it = kinds_.find(kind);
  return it != kinds_.end() ? &it->second : nullptr;
}

const KindInfo& PluginRegistry::require(const std::string& kind) const {
  if (const KindInfo* info = find(kind)) return *info;
  std::vector<std::string> names;
  for (const auto& [name, info] : kinds_) names.push_back(name);
  std::string message = "unknown plugin kind " + in_quotes(kind);
  const std::string close = closest_match(kind, names);
  if (!close.empty()) {
    message += " (did you mean " + in_quotes(close) + "?)";
  } else if (names.empty()) {
    message += " (no plugins are loaded; see `projtour plugins` and --plugin-path)";
  }
  throw PluginError(message);
}

std::vector<const KindInfo*> PluginRegistry::kinds() const {
  std::vector<const KindInfo*> out;
  for (const auto& [name, info] : kinds_) out.push_back(&info);
  return out;
}

std::shared_ptr<Behaviour> PluginRegistry::create_behaviour(const std::string& kind,
                                                            const Params& params,
                                                            const RunContext& run) const {
  return make_object<Behaviour>(require(kind), Family::behaviour, params, run);
}

std::shared_ptr<Driver> PluginRegistry::create_driver(const std::string& kind, const Params& params,
                                                      const RunContext& run) const {
  const KindInfo& info = require(kind);
  auto driver = make_object<Driver>(info, Family::driver, params, run);
  if (!implements(*driver, info.interface)) {
    throw PluginError(kind_prefix(info) + "declares interface " + in_quotes(info.interface) +
                      " but its object does not implement it");
  }
  return driver;
}

std::shared_ptr<Service> PluginRegistry::create_service(const std::string& kind,
                                                        const Params& params,
                                                        const RunContext& run) const {
  return make_object<Service>(require(kind), Family::service, params, run);
}

std::string PluginRegistry::validate_params(const std::string& kind, const Params& params) const {
  const KindInfo& info = require(kind);
  if (info.desc->validate == nullptr) return "";
  std::array<char, 1024> error{};
  int status = 0;
  try {
    status = info.desc->validate(&params, error.data(), error.size());
  } catch (const std::exception& e) {
    return e.what();
  }
  if (status == 0) return "";
  return error[0] != '\0' ? std::string(error.data()) : "invalid parameters";
}

}  // namespace projtour::host
