// Alignment speed and accuracy, the methods side by side on the same 50 rendered frames: the
// bunny at 1 m on a floor, Kinect-v1 noise, initial errors of exactly 5 cm and 5 degrees in
// random directions. Each iteration crops the frame around its guess and registers.
// Counters: median_ms (per alignment, cropping included), mean/max translation error (mm) and
// rotation error (deg) against the truth, success_pct (within 2 mm and 0.2 deg), iterations
// (mean per alignment).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <random>
#include <tuple>

#include "pcl_registration.hpp"
#include "projtour/perception/registration.hpp"
#include "projtour_test/rendered_scenes.hpp"

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
  std::shared_ptr<const perception::IcpModel> model;
  std::vector<Case> cases;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture out;
    const perception::TriangleMesh mesh =
        perception::load_mesh(PROJTOUR_SOURCE_DIR "/examples/models/bunny.ply");
    out.model = std::make_shared<const perception::IcpModel>(perception::sample_mesh(mesh, 0.003));
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
    const perception::RegistrationResult r = align_one(f, c);
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

perception::OrganizedCloud crop(const Fixture& f, const Case& c) {
  return perception::crop_sphere(c.frame, Eigen::Vector3d::Zero(), c.guess.translation(),
                                 f.model->bounding_radius_m() + kCropMarginM);
}

void BM_projective_icp(benchmark::State& state) {
  run(state, [](const Fixture& f, const Case& c) {
    return perception::align_projective_icp(*f.model, c.frame, Eigen::Vector3d::Zero(), c.guess,
                                            kCropMarginM);
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

// Scaling: the projective ICP against model size, distance to the target (so the crop's size)
// and initial error, one setting varied at a time from the main benchmark's (21,869 model
// points, 1 m, 5 cm / 5 deg), on 20 frames rendered per setting. Counters as above, plus
// scene_points: the crop's points the alignment read (the tiles near where the model landed).
struct ScalingCase {
  int model_points;
  double distance_m;
  double error_m;
};

const Fixture& scaling_fixture(const ScalingCase& s) {
  static std::map<std::tuple<int, double, double>, std::unique_ptr<Fixture>> made;
  auto& slot = made[{s.model_points, s.distance_m, s.error_m}];
  if (slot) return *slot;
  slot = std::make_unique<Fixture>();
  const perception::TriangleMesh mesh =
      perception::load_mesh(PROJTOUR_SOURCE_DIR "/examples/models/bunny.ply");
  const perception::IcpModel full(perception::sample_mesh(mesh, 0.003));
  // A prefix of the prepared model is a uniform subsample of it.
  ModelCloud cloud;
  const std::size_t n = std::min<std::size_t>(full.points().size(), s.model_points);
  cloud.points.assign(full.points().begin(), full.points().begin() + n);
  cloud.normals.assign(full.normals().begin(), full.normals().begin() + n);
  cloud.bounding_radius_m = full.bounding_radius_m();
  slot->model = std::make_shared<const perception::IcpModel>(cloud);
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> yaw(-0.35, 0.35), height(0.1, 0.4), side(-0.1, 0.1);
  for (int i = 0; i < 20; ++i) {
    Case c;
    c.truth = test::T_camera_model_facing(s.distance_m, height(rng) * s.distance_m) *
              Eigen::AngleAxisd(yaw(rng), Eigen::Vector3d::UnitZ());
    c.truth.translation().x() += side(rng) * s.distance_m;
    c.frame = test::render_on_floor(mesh, c.truth, true, 700 + i);
    c.guess = test::perturb(c.truth, s.error_m, deg_to_rad(5.0), rng);
    slot->cases.push_back(std::move(c));
  }
  return *slot;
}

void run_scaling(benchmark::State& state, const ScalingCase& s) {
  const Fixture& f = scaling_fixture(s);
  std::size_t i = 0, scene_points = 0, alignments = 0;
  std::vector<double> times_ms;
  int successes = 0;
  for (auto _ : state) {
    const Case& c = f.cases[i++ % f.cases.size()];
    const auto started = std::chrono::steady_clock::now();
    const perception::RegistrationResult r = perception::align_projective_icp(
        *f.model, c.frame, Eigen::Vector3d::Zero(), c.guess, kCropMarginM);
    times_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started)
            .count());
    benchmark::DoNotOptimize(r.T_camera_model);
    scene_points += r.scene_points;
    ++alignments;
    if (translation_distance_m(r.T_camera_model, c.truth) <= 0.002 &&
        rad_to_deg(rotation_angle_rad(r.T_camera_model, c.truth)) <= 0.2)
      ++successes;
  }
  std::sort(times_ms.begin(), times_ms.end());
  state.counters["median_ms"] = times_ms.empty() ? 0.0 : times_ms[times_ms.size() / 2];
  state.counters["success_pct"] = alignments ? 100.0 * successes / alignments : 0.0;
  state.counters["scene_points"] = alignments ? static_cast<double>(scene_points) / alignments : 0;
}

void BM_scaling_model_points(benchmark::State& state) {
  run_scaling(state, {static_cast<int>(state.range(0)), 1.0, 0.05});
}
void BM_scaling_distance_cm(benchmark::State& state) {
  run_scaling(state, {1 << 30, state.range(0) / 100.0, 0.05});
}
void BM_scaling_error_cm(benchmark::State& state) {
  run_scaling(state, {1 << 30, 1.0, state.range(0) / 100.0});
}

BENCHMARK(BM_scaling_model_points)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(200)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(5000)
    ->Arg(10000)
    ->Arg(20000);
BENCHMARK(BM_scaling_distance_cm)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(200)
    ->Arg(60)
    ->Arg(100)
    ->Arg(150)
    ->Arg(200)
    ->Arg(250);
BENCHMARK(BM_scaling_error_cm)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(200)
    ->Arg(1)
    ->Arg(5)
    ->Arg(10)
    ->Arg(20);

// Whole passes over the 50 frames, so every method sees exactly the same inputs.
BENCHMARK(BM_projective_icp)->Unit(benchmark::kMillisecond)->Iterations(kFrames * 10);
BENCHMARK(BM_pcl_icp)->Unit(benchmark::kMillisecond)->Iterations(kFrames);
BENCHMARK(BM_pcl_gicp)->Unit(benchmark::kMillisecond)->Iterations(kFrames);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
