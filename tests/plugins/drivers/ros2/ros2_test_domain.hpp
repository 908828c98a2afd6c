#pragma once
// A DDS domain of this test process's own: tests run in parallel (ctest -j), and two on one
// domain would hear each other. Domains are claimed with a lock file held for the process's
// life, so no two test processes of this machine share one; everything stays on loopback.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace projtour::test {

inline int claim_dds_domain() {
  static const int domain = [] {
    // 1..200: Cyclone maps domain d to ports 7400 + 250 d, all below 65535 up to 232.
    const int start = static_cast<int>(::getpid() % 200);
    for (int i = 0; i < 200; ++i) {
      const int d = 1 + (start + i) % 200;
      const std::string file = "/tmp/projtour-test-dds-domain-" + std::to_string(d) + ".lock";
      const int fd = ::open(file.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
      if (fd < 0) continue;
      if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return d;  // held (fd open) until the process ends
      ::close(fd);
    }
    throw std::runtime_error("no free DDS domain for the test (200 claimed)");
  }();
  // Children (projtour, the bridge) take ROS 2's environment.
  ::setenv("ROS_DOMAIN_ID", std::to_string(domain).c_str(), 1);
  ::setenv("ROS_LOCALHOST_ONLY", "1", 1);
  return domain;
}

}  // namespace projtour::test
