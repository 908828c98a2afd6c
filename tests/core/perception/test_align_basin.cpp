// The convergence basin of the default method: the bunny at 1 m, Kinect noise on, model error
// off, 500 trials from initial errors drawn uniformly up to 10 cm and 10 degrees (random axes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>

#include "projtour/perception/registration.hpp"
#include "projtour_test/rendered_scenes.hpp"

namespace projtour {
namespace {

struct BasinFigure {
  int trials = 0;
  int successes = 0;
  double median_ms = 0.0;
  double rate() const { return trials > 0 ? static_cast<double>(successes) / trials : 0.0; }
};

class Basin : public ::testing::Test {
 protected:
  static constexpr int kFrames = 6;

  static void SetUpTestSuite() {
    const perception::TriangleMesh mesh =
        perception::load_mesh(PROJTOUR_SOURCE_DIR "/examples/models/bunny.ply");
    model_ = new perception::IcpModel(perception::sample_mesh(mesh, 0.003));
    // A handful of true poses (the robot a little left or right, higher or lower, the bunny
    // turned), each rendered once and reused by many trials.
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> yaw(-0.35, 0.35), height(0.1, 0.4), side(-0.1, 0.1);
    for (int i = 0; i < kFrames; ++i) {
      Eigen::Isometry3d T = test::T_camera_model_facing(1.0, height(rng));
      T = T * Eigen::AngleAxisd(yaw(rng), Eigen::Vector3d::UnitZ());
      T.translation().x() += side(rng);
      truths_.push_back(T);
      frames_.push_back(test::render_on_floor(mesh, T, true, 100 + i));
    }
  }
  static void TearDownTestSuite() { delete model_; }

  static BasinFigure run(double max_trans_m, double max_rot_deg, int trials, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    BasinFigure fig;
    std::vector<double> times_ms;
    for (int t = 0; t < trials; ++t) {
      const int f = t % kFrames;
      const Eigen::Isometry3d guess = test::perturb(truths_[f], unit(rng) * max_trans_m,
                                                    deg_to_rad(unit(rng) * max_rot_deg), rng);
      const perception::RegistrationResult r = perception::align_projective_icp(
          *model_, frames_[f], Eigen::Vector3d::Zero(), guess, max_trans_m + 0.02);
      const double e_mm = translation_distance_m(r.T_camera_model, truths_[f]) * 1000.0;
      const double e_deg = rad_to_deg(rotation_angle_rad(r.T_camera_model, truths_[f]));
      ++fig.trials;
      if (e_mm <= 2.0 && e_deg <= 0.2) ++fig.successes;
      times_ms.push_back(r.time_ms);
    }
    std::sort(times_ms.begin(), times_ms.end());
    fig.median_ms = times_ms[times_ms.size() / 2];
    std::printf(
        "basin %3.0f cm / %3.0f deg: %d / %d within 2 mm and 0.2 deg (%.1f %%), median %.2f ms\n",
        max_trans_m * 100.0, max_rot_deg, fig.successes, fig.trials, 100.0 * fig.rate(),
        fig.median_ms);
    return fig;
  }

  static perception::IcpModel* model_;
  static std::vector<Eigen::Isometry3d> truths_;
  static std::vector<DepthFrame> frames_;
};
perception::IcpModel* Basin::model_ = nullptr;
std::vector<Eigen::Isometry3d> Basin::truths_;
std::vector<DepthFrame> Basin::frames_;

TEST_F(Basin, TenCentimetresTenDegreesConvergeInAtLeast99PercentOf500) {
  const BasinFigure fig = run(0.10, 10.0, 500, 1);
  EXPECT_GE(fig.rate(), 0.99);
}

TEST_F(Basin, FifteenAndTwentyArePrinted) {
  const BasinFigure f15 = run(0.15, 15.0, 500, 2);
  const BasinFigure f20 = run(0.20, 20.0, 500, 3);
  // Figures, not a bar: the basin shrinks gracefully rather than collapsing.
  EXPECT_GT(f15.rate(), 0.5);
  EXPECT_GT(f20.rate(), 0.2);
}

}  // namespace
}  // namespace projtour
