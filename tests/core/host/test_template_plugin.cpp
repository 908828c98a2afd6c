// Run by the install test: the template plugin, built out of tree against the installed
// package, as the installed core finds and runs it.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/fixture_support.hpp"

namespace fs = std::filesystem;

namespace {

fs::path env_path(const char* name) {
  const char* value = std::getenv(name);
  if (value == nullptr) throw std::runtime_error(std::string(name) + " is not set");
  return fs::canonical(value);
}

TEST(TemplatePlugin, InstalledCoreFindsItInItsPluginDirectory) {
  const fs::path prefix = env_path("PROJTOUR_INSTALL_PREFIX");
  // The core in this process is the installed one (else the test proves nothing).
  Dl_info info{};
  ASSERT_NE(dladdr(reinterpret_cast<void*>(&projtour::host::PluginRegistry::search_path), &info),
            0);
  const fs::path core = fs::canonical(info.dli_fname);
  ASSERT_EQ(core.string().rfind(prefix.string(), 0), 0u) << core;

  projtour::host::PluginRegistry registry;
  registry.load_directories(projtour::host::PluginRegistry::search_path({}));
  const projtour::host::KindInfo* hello = registry.find("hello");
  ASSERT_NE(hello, nullptr);
  EXPECT_EQ(hello->library, env_path("PROJTOUR_TEMPLATE_PLUGIN"));
}

TEST(TemplatePlugin, DeclaresItsKindAndWaitsOnMissionTime) {
  projtour::host::PluginRegistry registry;
  registry.load_library(env_path("PROJTOUR_TEMPLATE_PLUGIN"));
  const projtour::host::KindInfo& hello = registry.require("hello");
  EXPECT_EQ(hello.family, projtour::host::Family::behaviour);
  EXPECT_EQ(hello.plugin_name, "hello");
  EXPECT_EQ(hello.plugin_version, "1.0.0");
  ASSERT_EQ(hello.params.size(), 2u);
  EXPECT_EQ(hello.params[0].name, "duration_s");
  EXPECT_EQ(hello.params[0].type, projtour::ParamType::number);
  EXPECT_EQ(hello.params[0].default_value, "1.0");
  EXPECT_EQ(hello.outcomes, std::vector<std::string>{"succeeded"});

  projtour::host::Diagnostics diag;
  const auto params = projtour::testing::params_from_yaml(hello.params, "{duration_s: 3}", diag);
  ASSERT_FALSE(diag.has_errors()) << diag.format();
  EXPECT_EQ(registry.validate_params("hello", params), "");
  const auto negative = projtour::testing::params_from_yaml(hello.params, "{duration_s: -1}", diag);
  EXPECT_EQ(registry.validate_params("hello", negative), "duration_s must not be negative");

  projtour::testing::TestRun run;
  auto behaviour = registry.create_behaviour("hello", params, run.run);
  auto ctx = run.context(params);
  // The executor's part: the state's time, which the pause does not advance.
  projtour::StateTimer timer;
  ctx.state_timer = &timer;
  timer.restart(run.clock.now_s());
  behaviour->start(ctx);
  run.clock.advance(2.0);
  timer.pause(run.clock.now_s());
  behaviour->pause(ctx);
  run.clock.advance(5.0);  // paused time does not count
  timer.resume(run.clock.now_s());
  behaviour->resume(ctx);
  EXPECT_FALSE(behaviour->tick(ctx).has_value());
  run.clock.advance(1.0);
  const auto outcome = behaviour->tick(ctx);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded");
}

}  // namespace
