#pragma once
// A small dry-run world for the sim tests: the UD robot, a walled room, one flat sign (exact
// geometry, so the referee's figures are predictable) and optionally the bunny.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <memory>

#include "projtour/contract/context.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour_sim/sim_drivers.hpp"
#include "projtour_test/run_rig.hpp"
#include "sim_test_scenes.hpp"

namespace projtour::sim::testing {

// A board 2 cm deep, 40 cm wide, 30 cm high, centred on its origin, front face at x = +1 cm.
inline std::filesystem::path sign_off() {
  const auto path = test_temp_path("sign.off");
  std::ofstream out(path);
  out << "OFF\n8 6 0\n";
  for (int i = 0; i < 8; ++i) {
    out << ((i & 1) ? 0.01 : -0.01) << " " << ((i & 2) ? 0.2 : -0.2) << " "
        << ((i & 4) ? 0.15 : -0.15) << "\n";
  }
  out << "4 0 2 3 1\n4 4 5 7 6\n4 0 1 5 4\n4 2 6 7 3\n4 1 3 7 5\n4 0 4 6 2\n";
  return path;
}

struct Rig {
  test::RunRig rig{test::RunRig::RunDir::none};
  MissionSpec& mission = rig.mission;
  host::WorldSpec& world = rig.world;
  RunContext& run = rig.run;
  std::shared_ptr<SimWorld> sim;

  // The sign at (3, 0, 0.9) facing -x; the robot starts at `start` in a room [-1.5, 5] x
  // [-2.5, 2.5].
  explicit Rig(std::uint64_t seed = 1, Pose2D start = {1.5, 0.0, 0.0}, bool with_map = true) {
    host::Diagnostics diag;
    auto robot = host::load_robot(
        std::filesystem::path(PROJTOUR_SOURCE_DIR) / "examples/robot/ud.yaml", diag);
    if (!robot) throw std::runtime_error("cannot load ud.yaml");
    mission.name = "sim-test";
    mission.robot = *robot;
    mission.start = start;
    TargetSpec sign;
    sign.id = "sign";
    sign.model = sign_off();
    sign.T_map_model = isometry_from_xyz_rpy(3.0, 0.0, 0.9, 0, 0, kPi);
    // Corners on the front face, top-left, top-right, bottom-right, bottom-left as seen from the
    // front, where the model's +y is the viewer's right.
    sign.model_points = {Eigen::Vector3d(0.01, -0.1, 0.1), Eigen::Vector3d(0.01, 0.1, 0.1),
                         Eigen::Vector3d(0.01, 0.1, -0.05), Eigen::Vector3d(0.01, -0.1, -0.05)};
    sign.standoff_m = 1.0;
    mission.targets.push_back(sign);
    world.model_error = false;
    world.calibration_error_mm = 0.0;
    world.calibration_error_deg = 0.0;
    // The world alone, as SimWorld is made from it, without a run directory to write to.
    rig.use_world();
    run.dry_run = false;
    run.seed = seed;
    if (with_map) run.map = room_grid(-1.5f, 5.0f, -2.5f, 2.5f);
  }

  SimWorld& make() {
    sim = std::make_shared<SimWorld>(run);
    return *sim;
  }

  // Steps the world at 10 Hz up to t_s.
  void run_until(double t_s, double dt_s = 0.1) {
    for (double t = sim->time_s() + dt_s; t <= t_s + 1e-9; t += dt_s) sim->advance(t);
  }
};

// The pixels a perfect robot would choose: the true Model Points through the true projector.
inline std::array<Eigen::Vector2d, 4> true_pixels(const Rig& rig, const SimWorld& w) {
  std::array<Eigen::Vector2d, 4> px;
  const Eigen::Isometry3d T_projector_map = w.true_T_map_projector().inverse();
  for (int i = 0; i < 4; ++i) {
    const auto p = rig.mission.robot.projector.intrinsics.project(
        T_projector_map * w.true_T_map_model("sign") * rig.mission.targets[0].model_points[i]);
    EXPECT_TRUE(p);
    px[i] = *p;
  }
  return px;
}

// Aims the head at the sign from where the robot stands.
inline void aim_at_sign(Rig& rig, SimWorld& w) {
  const head::HeadKinematics head(rig.mission.robot);
  const Eigen::Vector3d p_base = w.true_T_map_base().inverse() * Eigen::Vector3d(3.0, 0.0, 0.9);
  const auto q = head.aim_projector_at(p_base);
  ASSERT_TRUE(q);
  w.command_head(*q);
  rig.run_until(w.time_s() + 2.0);
  ASSERT_TRUE(w.head_reached());
}

}  // namespace projtour::sim::testing
