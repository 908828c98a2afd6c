#include "projtour_test/file_modes.hpp"

#include <linux/capability.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>

namespace projtour::test {

namespace {

constexpr int kOverrides[] = {CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER};
constexpr const char* kSetpriv = "/usr/bin/setpriv";
constexpr const char* kDropped = "-dac_override,-dac_read_search,-fowner";

}  // namespace

bool give_up_file_mode_override() {
  if (::geteuid() != 0) return true;
  // glibc has no wrapper for capget/capset; libcap would be one more package for three bits.
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[_LINUX_CAPABILITY_U32S_3] = {};
  if (::syscall(SYS_capget, &header, data) != 0) return false;
  for (const int cap : kOverrides) {
    const unsigned bit = 1u << (cap % 32);
    data[cap / 32].effective &= ~bit;
    data[cap / 32].permitted &= ~bit;
    data[cap / 32].inheritable &= ~bit;
  }
  return ::syscall(SYS_capset, &header, data) == 0;
}

std::optional<std::vector<std::string>> with_file_modes_binding(std::vector<std::string> argv,
                                                                std::string& why) {
  if (::geteuid() != 0) return argv;
  if (::access(kSetpriv, X_OK) != 0) {
    why = std::string(kSetpriv) + " is missing (util-linux)";
    return std::nullopt;
  }
  const std::vector<std::string> prefix = {kSetpriv, std::string("--inh-caps=") + kDropped,
                                           std::string("--bounding-set=") + kDropped, "--"};
  // Dropping from the bounding set needs CAP_SETPCAP, which a container may not grant.
  const pid_t probe = ::fork();
  if (probe == 0) {
    ::execl(kSetpriv, kSetpriv, prefix[1].c_str(), prefix[2].c_str(), "--", "/bin/true",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int status = 0;
  if (probe < 0 || ::waitpid(probe, &status, 0) != probe || !WIFEXITED(status) ||
      WEXITSTATUS(status) != 0) {
    why = "setpriv cannot drop capabilities here (no CAP_SETPCAP?)";
    return std::nullopt;
  }
  argv.insert(argv.begin(), prefix.begin(), prefix.end());
  return argv;
}

}  // namespace projtour::test
