// The projtour command's launcher: `history` here, everything else in the module it loads
// (cli_module.hpp says why).
#include <dlfcn.h>

#include <filesystem>
#include <iostream>
#include <string>
#include <system_error>

#include "cli_module.hpp"
#include "projtour/history/history.hpp"

// The installed layout: bin/projtour, lib/projtour/libprojtour_cli.so.
#ifndef PROJTOUR_CLI_FROM_INSTALLED_EXE
#error "PROJTOUR_CLI_FROM_INSTALLED_EXE: set by executor/CMakeLists.txt"
#endif
// The build tree: projtour at its top, the libraries in lib/.
#ifndef PROJTOUR_CLI_FROM_BUILD_EXE
#error "PROJTOUR_CLI_FROM_BUILD_EXE: set by executor/CMakeLists.txt"
#endif

namespace {

namespace fs = std::filesystem;

// The module beside this executable, in the build tree or installed; empty when neither is. The
// build tree's comes first: a build-tree launcher's installed-layout path (the build directory's
// parent's lib/) may hold another, older installation's module, an installed launcher's
// build-tree path (bin/lib/) never does.
fs::path cli_module_path(std::string& why) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    why = "cannot find this executable (/proc/self/exe: " + ec.message() + ")";
    return {};
  }
  for (const char* relative : {PROJTOUR_CLI_FROM_BUILD_EXE, PROJTOUR_CLI_FROM_INSTALLED_EXE}) {
    const fs::path candidate = (exe.parent_path() / relative).lexically_normal();
    if (fs::is_regular_file(candidate, ec)) return candidate;
    why += (why.empty() ? "" : ", ") + candidate.string();
  }
  why = "the projtour installation is incomplete: no command module at " + why;
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::string(argv[1]) == "history") {
    try {
      return projtour::history_command(argc, argv, std::cout, std::cerr);
    } catch (const std::exception& e) {
      std::cerr << "projtour: " << e.what() << "\n";
      return 1;
    }
  }
  std::string why;
  const fs::path module = cli_module_path(why);
  if (module.empty()) {
    std::cerr << "projtour: " << why << "\n";
    return 1;
  }
  // RTLD_LOCAL: the module's symbols stay its own, as a linked executable's would, so a plugin
  // it loads later binds to its own libraries, never to the executor's internals.
  void* handle = ::dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    std::cerr << "projtour: cannot load " << module.string() << ": " << ::dlerror() << "\n";
    return 1;
  }
  const auto cli_main = reinterpret_cast<ProjtourCliMain>(::dlsym(handle, kProjtourCliMainSymbol));
  if (cli_main == nullptr) {
    std::cerr << "projtour: " << module.string() << " has no " << kProjtourCliMainSymbol
              << ": not this projtour's module\n";
    return 1;
  }
  // Never dlclosed: the commands leave threads and static state that end with the process.
  return cli_main(argc, argv);
}
