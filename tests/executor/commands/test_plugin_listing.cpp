// `projtour plugins`: the listing of the fixture plugins.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "projtour/commands/plugin_listing.hpp"
#include "projtour_test/fixture_support.hpp"

namespace fs = std::filesystem;
using projtour::testing::fixture;

namespace {

std::string listing_of(const std::vector<std::string>& fixtures) {
  projtour::host::PluginRegistry registry;
  for (const auto& name : fixtures) registry.load_library(fixture(name));
  std::ostringstream out;
  projtour::print_plugin_listing(registry, out);
  return out.str();
}

TEST(PluginListing, ShowsEveryKindWithParametersAndOutcomes) {
  const std::string text = listing_of({"pt_fixture_good"});
  const std::string library = fs::canonical(fixture("pt_fixture_good")).string();
  const std::string expected =
      "3 kinds from 1 plugin\n"
      "\n"
      "fixture_locator (service)\n"
      "  plugin       fixture_good 1.2.3\n"
      "  library      " +
      library +
      "\n"
      "  role         localization\n"
      "  description  logs its particle count\n"
      "  parameters   name       type     default  description\n"
      "               particles  integer  500      particle count\n"
      "\n"
      "fixture_projector (driver)\n"
      "  plugin       fixture_good 1.2.3\n"
      "  library      " +
      library +
      "\n"
      "  interface    projector\n"
      "  description  remembers whether it shows a frame\n"
      "  parameters   name       type     default  description\n"
      "               width_px   integer  1024     frame width\n"
      "               height_px  integer  768      frame height\n"
      "\n"
      "fixture_wait (behaviour)\n"
      "  plugin       fixture_good 1.2.3\n"
      "  library      " +
      library +
      "\n"
      "  description  waits, then succeeds\n"
      "  parameters   name             type     default     description\n"
      "               duration_s       number   2.5         mission time to wait\n"
      "               repeats          integer  3           how many times (at least 1)\n"
      "               fail_on_timeout  boolean  false       end with timed_out instead of "
      "succeeded\n"
      "               label            string   \"hello\"     text carried in the outcome "
      "message\n"
      "               gain             number   (required)  a required number with no default\n"
      "  outcomes     succeeded, timed_out (and failed, cancelled)\n"
      "  reads        localization.estimate (PoseEstimate2D)\n"
      "  writes       waited (double)\n";
  EXPECT_EQ(text, expected);
}

TEST(PluginListing, KindsOfSeveralPluginsAreSortedByName) {
  const std::string text = listing_of({"pt_fixture_throwing", "pt_fixture_good"});
  EXPECT_EQ(text.rfind("5 kinds from 2 plugins\n", 0), 0u) << text;
  const auto at = [&](const std::string& header) { return text.find("\n" + header + "\n"); };
  EXPECT_LT(at("fixture_create_throws (behaviour)"), at("fixture_locator (service)"));
  EXPECT_LT(at("fixture_projector (driver)"), at("fixture_tick_throws (behaviour)"));
  EXPECT_LT(at("fixture_tick_throws (behaviour)"), at("fixture_wait (behaviour)"));
  EXPECT_NE(text.find("  parameters   none\n"), std::string::npos) << text;
  EXPECT_NE(text.find("               after_ticks  integer  0        ticks that return nothing "
                      "before the throw\n"),
            std::string::npos)
      << text;
}

TEST(PluginListing, EmptyRegistrySaysSo) {
  EXPECT_EQ(listing_of({}), "no plugin kinds found\n");
}

TEST(PluginListing, CommandReportsSearchPathAndFailures) {
  std::ostringstream out;
  std::ostringstream err;
  const int status = projtour::run_plugins_command({PROJTOUR_FIXTURE_DIR}, out, err);
  EXPECT_EQ(status, 1);
  EXPECT_EQ(out.str().rfind(std::string("search path:\n  ") + PROJTOUR_FIXTURE_DIR + "\n", 0), 0u)
      << out.str();
  EXPECT_NE(out.str().find("\nfixture_wait (behaviour)\n"), std::string::npos);
  EXPECT_NE(err.str().find("projtour: plugins: " + fixture("pt_fixture_abi999").string() +
                           ": ABI version 999, this projtour needs " +
                           std::to_string(PROJTOUR_ABI_VERSION) + "\n"),
            std::string::npos)
      << err.str();
}

// A writable directory is an error of the command (exit 1); the option lets the same call list it.
TEST(PluginListing, WritableDirectoryFailsTheCommandUnlessAllowed) {
  projtour::testing::TempDir dir;
  fs::copy_file(fixture("pt_fixture_good"), dir / "libpt_fixture_good.so");
  fs::permissions(dir.path(), fs::perms::all);
  std::ostringstream out;
  std::ostringstream err;
  EXPECT_EQ(projtour::run_plugins_command({dir.path()}, out, err), 1);
  EXPECT_NE(err.str().find("projtour: plugins: " + dir.path().string() +
                           ": plugin directory is world-writable (mode 0777)"),
            std::string::npos)
      << err.str();
  EXPECT_EQ(out.str().find("fixture_wait (behaviour)"), std::string::npos) << out.str();

  std::ostringstream allowed_out;
  std::ostringstream allowed_err;
  EXPECT_EQ(projtour::run_plugins_command({dir.path()}, allowed_out, allowed_err,
                                          projtour::host::PluginLoadOptions{true}),
            0)
      << allowed_err.str();
  EXPECT_NE(allowed_out.str().find("\nfixture_wait (behaviour)\n"), std::string::npos);
}

// A broken copy that a good one further down replaced costs nothing: a warning, exit 0.
TEST(PluginListing, ReplacedBrokenFileIsAWarning) {
  projtour::testing::TempDir first("first");
  projtour::testing::TempDir second("second");
  std::ofstream(first / "libpt_fixture_good.so") << "not a library";
  fs::copy_file(fixture("pt_fixture_good"), second / "libpt_fixture_good.so");
  std::ostringstream out;
  std::ostringstream err;
  EXPECT_EQ(projtour::run_plugins_command({first.path(), second.path()}, out, err), 0);
  EXPECT_EQ(err.str(), "projtour: plugins: warning: " + (first / "libpt_fixture_good.so").string() +
                           ": not an ELF shared object (no ELF header) (" +
                           (second / "libpt_fixture_good.so").string() +
                           " further down the path was loaded instead)\n");
  EXPECT_NE(out.str().find("\nfixture_wait (behaviour)\n"), std::string::npos);
}

}  // namespace
