#pragma once
// What the plugin tests share: where the fixture plugins are, and a run to create objects in.
#include <filesystem>
#include <string>

#include "projtour/blackboard.hpp"
#include "projtour/clock.hpp"
#include "projtour/context.hpp"
#include "projtour/diagnostics.hpp"
#include "projtour/logger.hpp"
#include "projtour/params.hpp"

namespace projtour::testing {

// The fixture plugin file built from target `name` ("pt_fixture_good").
std::filesystem::path fixture(const std::string& name);

// A fresh, empty directory under the system temp dir, removed with the object.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A run with a mission clock the test advances; no mission, no drivers.
struct TestRun {
  SteppedClock clock;
  StderrLogger log{LogLevel::error};
  Blackboard blackboard;
  DriverSet drivers;
  RunContext run;
  CancelToken cancel;

  TestRun();
  Context context(const Params& params) const;
};

// Params read from YAML text against a schema; diagnostics land in `diag`.
Params params_from_yaml(const std::vector<ParamSpec>& schema, const std::string& yaml,
                        Diagnostics& diag);

}  // namespace projtour::testing
