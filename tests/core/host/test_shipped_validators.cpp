// The shipped plugins check their parameter values when the mission is loaded, not when the step
// first runs (nothing moves until everything the run will touch was checked): each kind's
// validator, called as the loader calls it, names the bad value and passes the defaults.
#include <gtest/gtest.h>

#include <ostream>

#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/fixture_support.hpp"

namespace {

struct BadValue {
  const char* library;
  const char* kind;
  const char* params_yaml;
  const char* expected_message;
};

void PrintTo(const BadValue& v, std::ostream* os) {
  *os << v.kind << " " << v.params_yaml;
}

class ShippedValidator : public ::testing::TestWithParam<BadValue> {
 protected:
  void SetUp() override {
    registry_.load_library(std::filesystem::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                           (std::string("libprojtour_") + GetParam().library + ".so"));
  }
  std::string validate(const std::string& yaml) {
    projtour::host::Diagnostics diag;
    const auto params =
        projtour::testing::params_from_yaml(registry_.require(GetParam().kind).params, yaml, diag);
    EXPECT_FALSE(diag.has_errors()) << diag.format();
    return registry_.validate_params(GetParam().kind, params);
  }
  projtour::host::PluginRegistry registry_;
};

TEST_P(ShippedValidator, PassesTheDefaultsAndNamesTheBadValue) {
  EXPECT_EQ(validate("{}"), "");
  EXPECT_EQ(validate(GetParam().params_yaml), GetParam().expected_message);
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, ShippedValidator,
    ::testing::Values(BadValue{"aim", "aim", "{aim_at: centre}",
                               "aim_at must be \"model_points\" or \"origin\", not \"centre\""},
                      BadValue{"aim", "aim", "{settle_s: -1}", "settle_s must be >= 0"},
                      BadValue{"project", "project", "{min_area_px2: -5}",
                               "planarity_warn_mm and min_area_px2 must be >= 0"},
                      BadValue{"navigate", "navigate", "{lookahead_m: 0}",
                               "lookahead_m: expected a positive number"},
                      BadValue{"ptu_dperception", "ptu_dperception", "{tilt_sign: 0.5}",
                               "tilt_sign must be 1 or -1"}),
    [](const ::testing::TestParamInfo<BadValue>& info) {
      return std::string(info.param.kind) + "_" + std::to_string(info.index);
    });

}  // namespace
