#include "projtour_test/temp_dir.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <iostream>
#include <optional>
#include <stdexcept>

namespace projtour::test {

namespace fs = std::filesystem;

namespace {

// Parameterised names carry '/', which would make a path of them.
std::string file_name_part(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '-' || c == '.';
    out += plain ? c : '_';
  }
  return out.substr(0, 120);
}

}  // namespace

std::string current_test_name() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  if (info == nullptr) return "";
  return std::string(info->test_suite_name()) + "." + info->name();
}

TempDir::TempDir(const std::string& tag) {
  std::string name = "projtour-" + std::to_string(::getpid());
  const std::string test = current_test_name();
  if (!test.empty()) name += "-" + file_name_part(test);
  if (!tag.empty()) name += "-" + file_name_part(tag);
  // mkdtemp's random part: the same test may make several, and a crashed run may have left one.
  std::string pattern = (fs::temp_directory_path() / (name + "-XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw std::runtime_error("cannot create a temporary directory " + pattern);
  }
  path_ = pattern;
}

TempDir::~TempDir() {
  release();
}

TempDir::TempDir(TempDir&& other) noexcept : path_(std::move(other.path_)), keep_(other.keep_) {
  other.path_.clear();
}

TempDir& TempDir::operator=(TempDir&& other) noexcept {
  if (this != &other) {
    release();
    path_ = std::move(other.path_);
    keep_ = other.keep_;
    other.path_.clear();
  }
  return *this;
}

void TempDir::release() {
  if (path_.empty()) return;
  // HasFailure() sees the running test's result (or the suite's, in SetUpTestSuite and
  // TearDownTestSuite); outside GoogleTest nothing has failed.
  if (keep_ || ::testing::Test::HasFailure()) {
    std::cerr << "kept " << path_.string()
              << (keep_ ? "" : " (the test failed: what it left is there)") << "\n";
  } else {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  path_.clear();
}

namespace {

// Ends the scratch directory with the test that made it.
class ScratchListener : public ::testing::EmptyTestEventListener {
 public:
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (dir && info.result()->Failed()) dir->keep();
    dir.reset();
  }
  std::optional<TempDir> dir;
};

ScratchListener& scratch_listener() {
  // Owned by GoogleTest once appended.
  static ScratchListener* listener = [] {
    auto* l = new ScratchListener;
    ::testing::UnitTest::GetInstance()->listeners().Append(l);
    return l;
  }();
  return *listener;
}

}  // namespace

const fs::path& scratch_dir() {
  ScratchListener& listener = scratch_listener();
  if (!listener.dir) listener.dir.emplace("scratch");
  return listener.dir->path();
}

}  // namespace projtour::test
