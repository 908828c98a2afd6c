#include "fixture_support.hpp"

#include <unistd.h>

#include <atomic>

#include "projtour/params_reader.hpp"
#include "projtour/yaml_reader.hpp"

namespace projtour::testing {

std::filesystem::path fixture(const std::string& name) {
  return std::filesystem::path(PROJTOUR_FIXTURE_DIR) / ("lib" + name + ".so");
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = std::filesystem::temp_directory_path() /
          ("projtour-plugins-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

TestRun::TestRun() {
  run.clock = &clock;
  run.log = &log;
  run.blackboard = &blackboard;
  run.drivers = &drivers;
  run.dry_run = true;
}

Context TestRun::context(const Params& params) const {
  Context ctx;
  ctx.run = &run;
  ctx.params = &params;
  ctx.cancel = &cancel;
  ctx.state_path = "test";
  return ctx;
}

Params params_from_yaml(const std::vector<ParamSpec>& schema, const std::string& yaml,
                        Diagnostics& diag) {
  const auto node = load_yaml_string(yaml, "params.yaml", diag);
  if (!node) return Params();
  return read_params(schema, YamlField(*node, "params.yaml", diag));
}

}  // namespace projtour::testing
