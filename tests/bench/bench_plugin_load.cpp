// What loading plugins costs at startup: each iteration uses a fresh registry, so it pays the
// full dlopen (relocations, RTLD_NOW binding), descriptor validation and dlclose.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "projtour/host/plugin_loader.hpp"

namespace {

const std::filesystem::path kFixtureDir = PROJTOUR_FIXTURE_DIR;

void BM_LoadPlugin(benchmark::State& state) {
  const auto file = kFixtureDir / "libpt_fixture_good.so";
  for (auto _ : state) {
    projtour::host::PluginRegistry registry;
    registry.load_library(file);
    benchmark::DoNotOptimize(registry.find("fixture_wait"));
  }
}
BENCHMARK(BM_LoadPlugin)->Unit(benchmark::kMicrosecond);

// A whole directory, good and bad files alike, as `projtour plugins` does.
void BM_LoadFixtureDirectory(benchmark::State& state) {
  std::size_t failures = 0;
  for (auto _ : state) {
    projtour::host::PluginRegistry registry;
    failures = registry.load_directories({kFixtureDir}).size();
    benchmark::DoNotOptimize(registry.kinds());
  }
  state.counters["failed_files"] = static_cast<double>(failures);
}
BENCHMARK(BM_LoadFixtureDirectory)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
