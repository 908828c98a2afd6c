// Time of one Monte Carlo localization update (prediction + laser likelihood + resampling) on
// the demo map, for several particle counts: a simulated 541-ray, 270 degree scan taken in the
// north corridor, the robot having moved 5 cm.
#include <benchmark/benchmark.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include "projtour/navigation/localizer.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace {

const projtour::Pose2D kPose{20.0, 1.0, 0.3};

std::shared_ptr<mrpt::obs::CObservation2DRangeScan> corridor_scan(
    const mrpt::maps::COccupancyGridMap2D& map) {
  auto scan = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
  scan->aperture = static_cast<float>(projtour::deg_to_rad(270.0));
  scan->maxRange = 20.0f;
  map.laserScanSimulator(*scan, mrpt::poses::CPose2D(kPose.x_m, kPose.y_m, kPose.yaw_rad), 0.6f,
                         541, 0.01f);
  return scan;
}

void BM_LocalizationUpdate(benchmark::State& state) {
  static const auto map =
      projtour::navigation::load_occupancy_grid(PROJTOUR_SOURCE_DIR "/maps/malaga_campus.yaml");
  const auto scan = corridor_scan(*map);
  projtour::navigation::LocalizerOptions options;
  options.particles = static_cast<int>(state.range(0));
  projtour::navigation::Localizer localizer(*map, options, 1);
  localizer.reset(kPose);
  const projtour::Pose2D step{0.05, 0.0, 0.0};
  for (auto _ : state) localizer.update(step, *scan);
  state.counters["particles"] = static_cast<double>(localizer.particle_count());
}
BENCHMARK(BM_LocalizationUpdate)->Arg(500)->Arg(1000)->Arg(5000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
