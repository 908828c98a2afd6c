// Mission parameters read against a kind's schema as the plugin declared it.
#include <gtest/gtest.h>

#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/fixture_support.hpp"

namespace {

using projtour::host::Diagnostics;
using projtour::testing::fixture;
using projtour::testing::params_from_yaml;
namespace host = projtour::host;

class KindParams : public ::testing::Test {
 protected:
  void SetUp() override { registry_.load_library(fixture("pt_fixture_good")); }
  const std::vector<projtour::ParamSpec>& schema() const {
    return registry_.require("fixture_wait").params;
  }
  projtour::host::PluginRegistry registry_;
};

TEST_F(KindParams, DefaultsFillWhatTheMissionLeavesOut) {
  host::Diagnostics diag;
  const auto params = params_from_yaml(schema(), "gain: 4\nlabel: sale\n", diag);
  ASSERT_FALSE(diag.has_errors()) << diag.format();
  EXPECT_DOUBLE_EQ(params.number("gain"), 4.0);
  EXPECT_EQ(params.string("label"), "sale");
  EXPECT_DOUBLE_EQ(params.number("duration_s"), 2.5);
  EXPECT_EQ(params.integer("repeats"), 3);
  EXPECT_FALSE(params.boolean("fail_on_timeout"));
  EXPECT_EQ(params.values().size(), 5u);
}

TEST_F(KindParams, WrongTypeIsReportedWithItsPlace) {
  host::Diagnostics diag;
  params_from_yaml(schema(), "gain: 1\nrepeats: many\n", diag);
  ASSERT_EQ(diag.error_count(), 1u) << diag.format();
  EXPECT_EQ(diag.items()[0].format(),
            "params.yaml:2:10: repeats: expected an integer, got \"many\"");
}

TEST_F(KindParams, UnknownParameterSuggestsTheDeclaredOne) {
  host::Diagnostics diag;
  params_from_yaml(schema(), "gain: 1\nduraton_s: 3\n", diag);
  ASSERT_EQ(diag.error_count(), 1u) << diag.format();
  EXPECT_EQ(diag.items()[0].format(),
            "params.yaml:2:1: duraton_s: unknown key \"duraton_s\"; did you mean \"duration_s\"?");
}

TEST_F(KindParams, RequiredParameterWithoutDefaultMustBeGiven) {
  host::Diagnostics diag;
  params_from_yaml(schema(), "{duration_s: 1}", diag);
  ASSERT_EQ(diag.error_count(), 1u) << diag.format();
  EXPECT_EQ(diag.items()[0].field_path, "gain");
  EXPECT_EQ(diag.items()[0].message, "missing required parameter (number)");
}

TEST_F(KindParams, DefaultsAloneNeedEveryRequiredValue) {
  EXPECT_THROW(projtour::host::default_params(schema()), std::invalid_argument);
  const auto params = projtour::host::default_params(registry_.require("fixture_projector").params);
  EXPECT_EQ(params.integer("width_px"), 1024);
  EXPECT_EQ(params.integer("height_px"), 768);
}

}  // namespace
