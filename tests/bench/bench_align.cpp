// Alignment speed and accuracy, the methods side by side on the same 50 rendered frames: the
// bunny at 1 m on a floor, Kinect-v1 noise, initial errors of exactly 5 cm and 5 degrees in
// random directions. Each iteration crops the frame around its guess and registers.
// Counters: median_ms (per alignment, cropping included), mean/max translation error (mm) and
// rotation error (deg) against the truth, success_pct (within 2 mm and 0.2 deg), iterations
// (mean per alignment).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>

#include "../align/rendered_scenes.hpp"
#include "pcl_registration.hpp"
#include "projtour/registration.hpp"

namespace projtour {
namespace {

constexpr int kFrames = 50;
constexpr double kCropMarginM = 0.1;

struct Case {
  DepthFrame frame;
  Eigen::Isometry3d truth;
  Eigen::Isometry3d guess;
};

struct Fixture {
  std::shared_ptr<const IcpModel> model;
  std::vector<Case> cases;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture out;
    const TriangleMesh mesh = load_mesh(PROJTOUR_SOURCE_DIR "/examples/models/bunny.ply");
    out.model = std::make_shared<const IcpModel>(sample_mesh(mesh, 0.003));
    std::mt19937 rng(2024);
    std::uniform_real_distribution<double> yaw(-0.35, 0.35), height(0.1, 0.4), side(-0.1, 0.1);
    for (int i = 0; i < kFrames; ++i) {
      Case c;
      c.truth = test::T_camera_model_facing(1.0, height(rng)) *
                Eigen::AngleAxisd(yaw(rng), Eigen::Vector3d::UnitZ());
      c.truth.translation().x() += side(rng);
      c.frame = test::render_on_floor(mesh, c.truth, true, 500 + i);
      c.guess = test::perturb(c.truth, 0.05, deg_to_rad(5.0), rng);
      out.cases.push_back(std::move(c));
    }
    return out;
  }();
  return f;
}

// Runs `align_one` over the frames in turn, one alignment per iteration.
template <typename AlignOne>
void run(benchmark::State& state, AlignOne align_one) {
  const Fixture& f = fixture();
  std::vector<double> times_ms, trans_mm, rot_deg;
  std::size_t i = 0;
  int successes = 0;
  double iterations = 0.0;
  for (auto _ : state) {
    const Case& c = f.cases[i++ % f.cases.size()];
    const auto started = std::chrono::steady_clock::now();
    const RegistrationResult r = align_one(f, c);
    times_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started)
            .count());
    benchmark::DoNotOptimize(r.T_camera_model);
    iterations += r.iterations;
    trans_mm.push_back(translation_distance_m(r.T_camera_model, c.truth) * 1000.0);
    rot_deg.push_back(rad_to_deg(rotation_angle_rad(r.T_camera_model, c.truth)));
    if (trans_mm.back() <= 2.0 && rot_deg.back() <= 0.2) ++successes;
  }
  const auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  const auto max = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  };
  std::vector<double> sorted = times_ms;
  std::sort(sorted.begin(), sorted.end());
  state.counters["median_ms"] = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  state.counters["mean_mm"] = mean(trans_mm);
  state.counters["max_mm"] = max(trans_mm);
  state.counters["mean_deg"] = mean(rot_deg);
  state.counters["max_deg"] = max(rot_deg);
  state.counters["iterations"] = times_ms.empty() ? 0.0 : iterations / times_ms.size();
  state.counters["success_pct"] = times_ms.empty() ? 0.0 : 100.0 * successes / times_ms.size();
}

OrganizedCloud crop(const Fixture& f, const Case& c) {
  return crop_sphere(c.frame, Eigen::Vector3d::Zero(), c.guess.translation(),
                     f.model->bounding_radius_m() + kCropMarginM);
}

void BM_projective_icp(benchmark::State& state) {
  run(state, [](const Fixture& f, const Case& c) {
    return align_projective_icp(*f.model, c.frame, Eigen::Vector3d::Zero(), c.guess, kCropMarginM);
  });
}

void BM_pcl(benchmark::State& state, align::PclMethod method) {
  const align::PclRegistration pcl(fixture().model, method);
  run(state, [&](const Fixture& f, const Case& c) { return pcl.align(crop(f, c), c.guess); });
}

void BM_pcl_icp(benchmark::State& state) {
  BM_pcl(state, align::PclMethod::icp);
}
void BM_pcl_gicp(benchmark::State& state) {
  BM_pcl(state, align::PclMethod::gicp);
}

// Whole passes over the 50 frames, so every method sees exactly the same inputs.
BENCHMARK(BM_projective_icp)->Unit(benchmark::kMillisecond)->Iterations(kFrames * 10);
BENCHMARK(BM_pcl_icp)->Unit(benchmark::kMillisecond)->Iterations(kFrames);
BENCHMARK(BM_pcl_gicp)->Unit(benchmark::kMillisecond)->Iterations(kFrames);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
