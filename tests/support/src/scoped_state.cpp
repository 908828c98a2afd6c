#include "projtour_test/scoped_state.hpp"

#include <stdlib.h>

#include <fstream>

namespace projtour::test {

ScopedEnv::ScopedEnv(const std::string& name, const char* value) : name_(name) {
  if (const char* old = std::getenv(name.c_str())) old_ = old;
  if (value != nullptr) {
    ::setenv(name.c_str(), value, 1);
  } else {
    ::unsetenv(name.c_str());
  }
}

ScopedEnv::~ScopedEnv() {
  if (old_) {
    ::setenv(name_.c_str(), old_->c_str(), 1);
  } else {
    ::unsetenv(name_.c_str());
  }
}

ScopedCurrentPath::ScopedCurrentPath(const std::filesystem::path& dir)
    : old_(std::filesystem::current_path()) {
  std::filesystem::current_path(dir);
}

ScopedCurrentPath::~ScopedCurrentPath() {
  std::error_code ec;
  std::filesystem::current_path(old_, ec);
}

bool mapped_in_this_process(const std::filesystem::path& file) {
  const std::string wanted = std::filesystem::weakly_canonical(file).string();
  std::ifstream maps("/proc/self/maps");
  for (std::string line; std::getline(maps, line);) {
    const auto slash = line.find('/');
    if (slash == std::string::npos) continue;
    std::string mapped = line.substr(slash);
    // The kernel appends " (deleted)" once the file is unlinked; the mapping is still there.
    const std::string deleted = " (deleted)";
    if (mapped.size() > deleted.size() &&
        mapped.compare(mapped.size() - deleted.size(), deleted.size(), deleted) == 0) {
      mapped.erase(mapped.size() - deleted.size());
    }
    if (mapped == wanted) return true;
  }
  return false;
}

}  // namespace projtour::test
