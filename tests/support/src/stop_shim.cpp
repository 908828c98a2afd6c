// Preloaded into a child (process.hpp's stop_after_write / stop_after_handler_for) so it stops
// itself at an exact point of its run: the test then signals it knowing what it was doing,
// however fast or slow the machine. The program itself is unchanged; only write(2), writev(2)
// and sigaction(2) pass through here.
#include <dlfcn.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <string>

namespace {

std::atomic<bool> g_write_stop_done{false};
std::atomic<bool> g_handler_stop_done{false};

template <typename F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

void stop_if_written(const char* data, size_t n) {
  const char* marker = getenv("PROJTOUR_TEST_STOP_AFTER_WRITE");
  if (marker == nullptr || *marker == '\0' || g_write_stop_done.load()) return;
  if (memmem(data, n, marker, strlen(marker)) == nullptr) return;
  if (g_write_stop_done.exchange(true)) return;
  raise(SIGSTOP);
}

}  // namespace

extern "C" {

ssize_t write(int fd, const void* buf, size_t n) {
  static const auto real = next<ssize_t (*)(int, const void*, size_t)>("write");
  const ssize_t written = real(fd, buf, n);
  if (written > 0) stop_if_written(static_cast<const char*>(buf), static_cast<size_t>(written));
  return written;
}

ssize_t writev(int fd, const struct iovec* iov, int count) {
  static const auto real = next<ssize_t (*)(int, const struct iovec*, int)>("writev");
  const ssize_t written = real(fd, iov, count);
  if (written > 0 && getenv("PROJTOUR_TEST_STOP_AFTER_WRITE") != nullptr) {
    std::string bytes;
    for (int i = 0; i < count && bytes.size() < static_cast<size_t>(written); ++i) {
      bytes.append(static_cast<const char*>(iov[i].iov_base), iov[i].iov_len);
    }
    bytes.resize(static_cast<size_t>(written));
    stop_if_written(bytes.data(), bytes.size());
  }
  return written;
}

int sigaction(int signum, const struct sigaction* act, struct sigaction* old) {
  static const auto real =
      next<int (*)(int, const struct sigaction*, struct sigaction*)>("sigaction");
  const int result = real(signum, act, old);
  const char* wanted = getenv("PROJTOUR_TEST_STOP_AFTER_HANDLER");
  if (result == 0 && wanted != nullptr && act != nullptr && atoi(wanted) == signum &&
      act->sa_handler != SIG_DFL && act->sa_handler != SIG_IGN &&
      !g_handler_stop_done.exchange(true)) {
    raise(SIGSTOP);
  }
  return result;
}

}  // extern "C"
