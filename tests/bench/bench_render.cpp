// One 640x480 depth frame of 4 bunnies, the walls of a room and the floor, on one thread.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <ctime>
#include <random>

#include "../plugins/sim/sim_test_scenes.hpp"
#include "projtour/perception/model.hpp"
#include "projtour_sim/depth_renderer.hpp"
#include "projtour_sim/kinect_noise.hpp"

namespace {

using namespace projtour;

struct BenchScene {
  sim::Scene scene;
  PinholeModel intrinsics = sim::testing::kinect_intrinsics();
  Eigen::Isometry3d T_world_camera =
      sim::testing::camera_optical(0.0, 0.0, 1.2, 0.0, deg_to_rad(10.0));

  BenchScene() {
    const perception::TriangleMesh bunny =
        perception::load_mesh(std::string(PROJTOUR_SOURCE_DIR) + "/examples/models/bunny.ply");
    sim::SceneBuilder builder;
    for (int k = 0; k < 4; ++k) {
      // Facing the camera (+x of the model towards -x of the world), side by side.
      builder.add_mesh(bunny, isometry_from_xyz_rpy(1.6, -0.75 + 0.5 * k, 0.9, 0, 0, kPi), 2 + k);
    }
    builder.set_floor(0.0, 0);
    builder.add_occupancy_walls(*sim::testing::room_grid(-1.0, 3.5, -2.5, 2.5), 2.0, 1);
    scene = builder.build();
  }
};

// CPU time, not wall time: the figure is "on one core", whatever else the machine is doing.
void report_cpu_ms_per_frame(benchmark::State& state, std::clock_t start) {
  const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
  state.counters["cpu_ms_per_frame"] = benchmark::Counter(
      cpu_ms / static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1)));
}

const BenchScene& bench_scene() {
  static const BenchScene s;
  return s;
}

void BM_RenderIdeal(benchmark::State& state) {
  const BenchScene& s = bench_scene();
  const sim::DepthRenderer renderer(s.intrinsics);
  sim::IdealDepth ideal;
  const std::clock_t start = std::clock();
  for (auto _ : state) {
    renderer.render(s.scene, s.T_world_camera, ideal, 4.0);
    benchmark::DoNotOptimize(ideal.depth_m.data());
  }
  report_cpu_ms_per_frame(state, start);
  state.counters["triangles"] = static_cast<double>(s.scene.triangle_count());
}
BENCHMARK(BM_RenderIdeal)->Unit(benchmark::kMillisecond);

// range(0) = 1: with the structured-light artefacts (shadows, flying pixels, correlated noise).
sim::KinectNoiseParams noise_params(const benchmark::State& state) {
  sim::KinectNoiseParams params;
  params.shadows = params.flying_pixels = params.correlated_noise = state.range(0) != 0;
  return params;
}

void BM_RenderWithKinectNoise(benchmark::State& state) {
  const BenchScene& s = bench_scene();
  const sim::DepthRenderer renderer(s.intrinsics);
  const sim::KinectNoiseParams params = noise_params(state);
  sim::IdealDepth ideal;
  std::mt19937_64 rng(1);
  const std::clock_t start = std::clock();
  for (auto _ : state) {
    renderer.render(s.scene, s.T_world_camera, ideal, 4.0);
    DepthFrame frame = sim::apply_kinect_noise(ideal, s.intrinsics, params, rng);
    benchmark::DoNotOptimize(frame.depth_mm.data());
  }
  report_cpu_ms_per_frame(state, start);
}
BENCHMARK(BM_RenderWithKinectNoise)
    ->ArgName("artefacts")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);

// The noise model alone, on one rendered frame: what the artefacts add to every frame.
void BM_KinectNoise(benchmark::State& state) {
  const BenchScene& s = bench_scene();
  sim::IdealDepth ideal;
  sim::DepthRenderer(s.intrinsics).render(s.scene, s.T_world_camera, ideal, 4.0);
  const sim::KinectNoiseParams params = noise_params(state);
  std::mt19937_64 rng(1);
  const std::clock_t start = std::clock();
  for (auto _ : state) {
    DepthFrame frame = sim::apply_kinect_noise(ideal, s.intrinsics, params, rng);
    benchmark::DoNotOptimize(frame.depth_mm.data());
  }
  report_cpu_ms_per_frame(state, start);
}
BENCHMARK(BM_KinectNoise)->ArgName("artefacts")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
