#pragma once
// What the plugin tests share: where the fixture plugins are, and a run to create objects in.
#include <filesystem>
#include <string>

#include <vector>

#include "projtour/contract/context.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour_test/run_rig.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::testing {

// The fixture plugin file built from target `name` ("pt_fixture_good").
std::filesystem::path fixture(const std::string& name);

using TempDir = test::TempDir;

// A run with a mission clock the test advances; no mission, no drivers.
struct TestRun : test::RunRig {
  Context context(const Params& params) const { return RunRig::context(&params); }
};

// Params read from YAML text against a schema; diagnostics land in `diag`.
Params params_from_yaml(const std::vector<ParamSpec>& schema, const std::string& yaml,
                        host::Diagnostics& diag);

}  // namespace projtour::testing
