// The calibrate step's measurement, one thread: 28 rendered 640x480 colour frames of the Gray
// code on the sign at 1.4 m decoded in a region around it, the Kinect depth frame registered
// into the colour image, the blocks lifted to 3-D and the camera-projector transform fitted from
// a belief 10 mm / 1 degree off. BM_calibration is the whole of it (the budget: 50 ms); the
// others are its parts. Counters: blocks decoded, points lifted, inliers, rms_px of the fit, and
// its error at the target (target_mm: the sign's corners as the projector images them, across
// its rays) and of the transform (position_mm, rotation_deg). BM_outline_match is verify's
// outline check.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "../core/light/light_scene.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/light/gray_code.hpp"
#include "projtour/light/light_check.hpp"
#include "projtour/light/outline_match.hpp"
#include "projtour/light/projector_fit.hpp"
#include "projtour/light/registered_depth.hpp"

namespace projtour {
namespace {

struct Fixture {
  test::LightRig rig = test::default_rig();
  test::Scene scene = test::sign_scene();
  light::GrayCodeSequence sequence{rig.projector, light::GrayCodeSettings{}};
  std::vector<ColourFrame> frames;
  DepthFrame depth;
  cv::Rect roi;
  Eigen::Isometry3d belief;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture out;
    const test::ColourRenderer renderer(out.rig, out.scene);
    out.frames = test::render_sequence(renderer, out.sequence, cv::Mat(), 1);
    out.depth = test::render_depth(out.rig, out.scene, 2);
    out.roi = test::colour_roi(out.rig.colour, test::rectangle_corners(out.scene.surfaces[0]), 8);
    out.belief = test::perturb(out.rig.T_camera_projector, 0.010, deg_to_rad(1.0), 3).inverse();
    return out;
  }();
  return f;
}

void report(benchmark::State& state, const Fixture& f, const light::DecodeResult& decoded,
            const test::Correspondences& lifted, const light::ProjectorFit& fit) {
  state.counters["blocks"] = static_cast<double>(decoded.blocks.size());
  state.counters["lifted"] = static_cast<double>(lifted.points_camera.size());
  state.counters["inliers"] = fit.inliers;
  state.counters["rms_px"] = fit.rms_px;
  if (!fit.T_projector_camera) {
    state.SkipWithError(fit.problem.c_str());
    return;
  }
  const Eigen::Isometry3d truth = f.rig.T_projector_camera();
  double target_mm = 0.0;
  for (const Eigen::Vector3d& p : test::rectangle_corners(f.scene.surfaces[0])) {
    const double px = (*f.rig.projector.project(*fit.T_projector_camera * p) -
                       *f.rig.projector.project(truth * p))
                          .norm();
    target_mm = std::max(target_mm, 1000.0 * px * (truth * p).z() / f.rig.projector.fx);
  }
  const Eigen::Isometry3d T_camera_projector = fit.T_projector_camera->inverse();
  state.counters["target_mm"] = target_mm;
  state.counters["position_mm"] =
      1000.0 * translation_distance_m(T_camera_projector, f.rig.T_camera_projector);
  state.counters["rotation_deg"] =
      rad_to_deg(rotation_angle_rad(T_camera_projector, f.rig.T_camera_projector));
}

void BM_calibration(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  light::DecodeResult decoded;
  test::Correspondences lifted;
  light::ProjectorFit fit;
  for (auto _ : state) {
    decoded = light::decode(f.sequence, f.frames, f.roi);
    const light::RegisteredDepth depth =
        light::register_depth(f.depth, f.rig.depth_to_color_m, f.rig.colour);
    lifted = test::lift_blocks(decoded, depth);
    fit = light::fit_projector_pose(lifted.points_camera, lifted.projector_px, f.rig.projector,
                                    f.belief);
    benchmark::DoNotOptimize(fit.T_projector_camera);
  }
  report(state, f, decoded, lifted, fit);
}

void BM_decode(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  for (auto _ : state) {
    const light::DecodeResult decoded = light::decode(f.sequence, f.frames, f.roi);
    benchmark::DoNotOptimize(decoded.blocks.data());
  }
}

void BM_register_depth(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  for (auto _ : state) {
    const light::RegisteredDepth depth =
        light::register_depth(f.depth, f.rig.depth_to_color_m, f.rig.colour);
    benchmark::DoNotOptimize(depth.z_m.data());
  }
}

void BM_lift(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  const light::DecodeResult decoded = light::decode(f.sequence, f.frames, f.roi);
  const light::RegisteredDepth depth =
      light::register_depth(f.depth, f.rig.depth_to_color_m, f.rig.colour);
  for (auto _ : state) {
    const test::Correspondences lifted = test::lift_blocks(decoded, depth);
    benchmark::DoNotOptimize(lifted.points_camera.data());
  }
}

void BM_fit(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  const light::DecodeResult decoded = light::decode(f.sequence, f.frames, f.roi);
  const test::Correspondences lifted = test::lift_blocks(
      decoded, light::register_depth(f.depth, f.rig.depth_to_color_m, f.rig.colour));
  light::ProjectorFit fit;
  for (auto _ : state) {
    fit = light::fit_projector_pose(lifted.points_camera, lifted.projector_px, f.rig.projector,
                                    f.belief);
    benchmark::DoNotOptimize(fit.T_projector_camera);
  }
  report(state, f, decoded, lifted, fit);
}

// Verify's outline check: the sign's model, slid 25 mm along its face, matched against the dark
// frame's edges (search +-80 px, verify's default). Counters: the slide it finds back (found_mm, of
// 25) and the share of the outline matched.
void BM_outline_match(benchmark::State& state) {
  cv::setNumThreads(1);
  const Fixture& f = fixture();
  const test::ColourRenderer renderer(f.rig, f.scene);
  const ColourFrame dark =
      renderer.render(cv::Mat::zeros(f.rig.projector.height, f.rig.projector.width, CV_8UC3), 7);
  Eigen::Isometry3d T_true;
  const ModelCloud model = test::rectangle_model(f.scene.surfaces[0], 0.003, T_true);
  const Eigen::Isometry3d T_slid = T_true * Eigen::Translation3d(0.025, 0.0, 0.0);
  const std::vector<float> model_z = light::model_depth(model, T_slid, f.rig.colour);
  light::OutlineSettings settings;
  settings.search_px = 80;
  std::optional<light::OutlineMatch> match;
  for (auto _ : state) {
    match = light::match_outline(dark, model_z, settings);
    benchmark::DoNotOptimize(match);
  }
  if (!match) {
    state.SkipWithError("no outline");
    return;
  }
  const Eigen::Vector3d slide = light::slide_for_shift(f.rig.colour, T_slid.translation(),
                                                       T_slid.linear().col(2), match->shift_px);
  state.counters["found_mm"] = 1000.0 * slide.norm();
  state.counters["matched"] = match->matched_fraction;
}

BENCHMARK(BM_calibration)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_outline_match)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_decode)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_register_depth)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_lift)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_fit)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace projtour

BENCHMARK_MAIN();
