// The simulated world: base, laser, head, camera, projector, the referee and the faults.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "projtour/head/kinematics.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour/host/world.hpp"
#include "projtour/perception/model.hpp"
#include "sim_world_rig.hpp"

namespace projtour::sim {
namespace {

using testing::aim_at_sign;
using testing::Rig;
using testing::true_pixels;

TEST(SimBase, OdometryDriftWithinConfiguredRange) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    Rig rig(seed, {-1.0, 0.0, 0.0});
    rig.world.odometry_trans_noise_frac = 0.03;
    SimWorld& w = rig.make();
    w.advance(0.0);
    w.command_velocity(0.5, 0.0);
    rig.run_until(8.0);
    const Pose2D truth = pose2d_from_isometry(w.true_T_map_base());
    const Pose2D odo = w.odometry().pose;
    const double travelled = truth.x_m + 1.0;
    EXPECT_GT(travelled, 3.5) << seed;
    EXPECT_FALSE(w.base_blocked());
    const double drift = std::hypot(odo.x_m - truth.x_m, odo.y_m - truth.y_m) / travelled;
    EXPECT_GT(drift, 0.3 * 0.03) << seed;
    EXPECT_LT(drift, 1.5 * 0.03) << seed;
    EXPECT_NEAR(w.odometry().v_mps, 0.5, 0.05);
  }
}

TEST(SimBase, VelocityLimitsAndBumper) {
  Rig rig(1, {3.5, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  w.command_velocity(5.0, 0.0);  // clamped to 0.5 m/s
  rig.run_until(1.0);
  EXPECT_LT(pose2d_from_isometry(w.true_T_map_base()).x_m, 3.5 + 0.5 + 1e-6);
  rig.run_until(6.0);
  // The wall's inner face is at x = 5; the bumper stops the centre 15 cm before it.
  const Pose2D truth = pose2d_from_isometry(w.true_T_map_base());
  EXPECT_TRUE(w.base_blocked());
  EXPECT_LT(truth.x_m, 5.0 - 0.1);
  EXPECT_GT(truth.x_m, 4.6);
  // Backing away works.
  w.command_velocity(-0.3, 0.0);
  rig.run_until(7.0);
  EXPECT_FALSE(w.base_blocked());
  EXPECT_LT(pose2d_from_isometry(w.true_T_map_base()).x_m, truth.x_m - 0.1);
}

TEST(SimLaser, RangesAgainstAKnownWall) {
  Rig rig(1, {0.0, 0.0, 0.0});
  rig.mission.targets.clear();
  SimWorld& w = rig.make();
  w.advance(0.0);
  const auto scan = w.take_scan();
  ASSERT_TRUE(scan);
  EXPECT_FALSE(w.take_scan());  // taken
  ASSERT_EQ(scan->ranges_m.size(), 541u);
  EXPECT_NEAR(scan->angle_min_rad, -deg_to_rad(135.0), 1e-9);
  EXPECT_NEAR(scan->angle_increment_rad, deg_to_rad(0.5), 1e-9);
  // Straight ahead from the laser 0.2 m in front of the centre: the wall at x = 5.
  ASSERT_TRUE(scan->valid[270]);
  EXPECT_NEAR(scan->ranges_m[270], 4.8, 0.06);
  // Left (+90 deg): wall at y = 2.5, laser on the centre line.
  ASSERT_TRUE(scan->valid[450]);
  EXPECT_NEAR(scan->ranges_m[450], 2.5, 0.06);
  // The next scan comes at 10 Hz.
  w.advance(0.05);
  EXPECT_FALSE(w.take_scan());
  w.advance(0.1);
  EXPECT_TRUE(w.take_scan());
}

TEST(SimPanTilt, RateLimitedAndSettles) {
  Rig rig;
  SimWorld& w = rig.make();
  w.advance(0.0);
  EXPECT_TRUE(w.head_reached());
  w.command_head({deg_to_rad(60.0), deg_to_rad(-10.0)});
  rig.run_until(0.5, 0.05);
  EXPECT_NEAR(rad_to_deg(w.true_head().pan_rad), 30.0, 0.01);
  EXPECT_NEAR(rad_to_deg(w.true_head().tilt_rad), -10.0, 1e-9);
  EXPECT_FALSE(w.head_reached());
  rig.run_until(1.0, 0.05);
  EXPECT_NEAR(rad_to_deg(w.true_head().pan_rad), 60.0, 1e-9);
  rig.run_until(1.2, 0.05);
  EXPECT_TRUE(w.head_reached());
  // Encoder noise: measured differs from the truth by a few hundredths of a degree.
  EXPECT_NE(w.measured_head().pan_rad, w.true_head().pan_rad);
  EXPECT_NEAR(rad_to_deg(w.measured_head().pan_rad), 60.0, 0.1);
  // Commands beyond the limits stop at the limit.
  w.command_head({deg_to_rad(300.0), 0.0});
  rig.run_until(5.0, 0.05);
  EXPECT_NEAR(rad_to_deg(w.true_head().pan_rad), 170.0, 1e-9);
}

TEST(SimReferee, ZeroForTruePixelsAndExpectedForAnOffset) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  const auto exact = w.evaluate_projection("sign", px);
  ASSERT_TRUE(exact);
  EXPECT_LT(exact->mean_mm(), 0.01);
  EXPECT_LT(exact->mean_px(), 1e-6);
  // 10 projector pixels at about 0.98 m with f = 1920 px: about 5.1 mm on the board.
  auto shifted = px;
  for (auto& p : shifted) p.x() += 10.0;
  const auto off = w.evaluate_projection("sign", shifted);
  ASSERT_TRUE(off);
  EXPECT_NEAR(off->mean_px(), 10.0, 1e-6);
  EXPECT_NEAR(off->mean_mm(), 10.0 * 0.98 / 1920.0 * 1000.0, 0.4);
  EXPECT_FALSE(w.evaluate_projection("nope", px));
  // A pixel off the board lands on the Model Points' plane instead: still a finite error.
  auto outside = px;
  outside[0].x() -= 600.0;
  const auto plane = w.evaluate_projection("sign", outside);
  ASSERT_TRUE(plane);
  EXPECT_GT(plane->error_mm[0], 250.0);
  EXPECT_LT(plane->error_mm[0], 350.0);
}

TEST(SimReferee, CalibrationErrorShowsInTheProjection) {
  Rig rig(3, {2.0, 0.0, 0.0});
  rig.world.calibration_error_mm = 1.0;
  rig.world.calibration_error_deg = 0.1;
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  // Pixels the robot computes with the robot file's (believed) projector mount.
  const head::HeadKinematics believed(rig.mission.robot);
  const Eigen::Isometry3d T_map_projector_believed =
      w.true_T_map_base() * believed.T_base_projector(w.true_head());
  std::array<Eigen::Vector2d, 4> px;
  for (int i = 0; i < 4; ++i) {
    px[i] = *rig.mission.robot.projector.intrinsics.project(T_map_projector_believed.inverse() *
                                                            w.true_T_map_model("sign") *
                                                            rig.mission.targets[0].model_points[i]);
  }
  const auto truth = w.evaluate_projection("sign", px);
  ASSERT_TRUE(truth);
  // 0.1 deg at 1 m is 1.7 mm, plus up to 1 mm of offset.
  EXPECT_GT(truth->mean_mm(), 0.3);
  EXPECT_LT(truth->mean_mm(), 3.0);
}

TEST(SimReferee, WritesBeforeAndAfterViews) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  auto before = px;
  for (auto& p : before) p += Eigen::Vector2d(40.0, -25.0);
  const auto dir = testing::test_temp_path("views");
  std::filesystem::remove_all(dir);
  w.write_projection_views("sign", before, px, std::nullopt, dir);
  for (const char* name : {"before.png", "after.png"}) {
    const cv::Mat image = cv::imread((dir / name).string());
    ASSERT_FALSE(image.empty()) << name;
    // The virtual camera's view, and the colour camera's beside it.
    EXPECT_EQ(image.cols, 640 + 640);
    EXPECT_EQ(image.rows, 480);
    // The shaded board fills the middle.
    const cv::Vec3b centre = image.at<cv::Vec3b>(240, 320);
    EXPECT_GT(centre[0], 150) << name;
  }
}

// Pixels of a frame within a depth band.
int sign_pixels(const DepthFrame& f, double lo_mm, double hi_mm) {
  int n = 0;
  for (std::uint16_t d : f.depth_mm) n += d >= lo_mm && d <= hi_mm;
  return n;
}

TEST(SimCamera, SeesTheSignAtItsDistanceDeterministically) {
  auto frames_of = [](std::uint64_t seed) {
    Rig rig(seed, {2.0, 0.0, 0.0});
    SimWorld& w = rig.make();
    w.advance(0.0);
    std::vector<DepthFrame> out;
    for (int k = 0; k < 2; ++k) {
      rig.run_until(w.time_s() + 0.1);
      auto f = w.grab();
      EXPECT_TRUE(f);
      out.push_back(*f);
    }
    return out;
  };
  const auto a = frames_of(4), b = frames_of(4), c = frames_of(5);
  EXPECT_EQ(a[0].width, 640);
  EXPECT_EQ(a[0].t_s, 0.1);
  EXPECT_EQ(a[1].sequence, 2u);
  EXPECT_EQ(a[0].depth_mm, b[0].depth_mm);
  EXPECT_EQ(a[1].depth_mm, b[1].depth_mm);
  EXPECT_NE(a[0].depth_mm, c[0].depth_mm);
  // The board (and the floor in front of it) about a metre from the camera fill a good part of
  // the image.
  EXPECT_GT(sign_pixels(a[0], 800, 1200), 20000);
}

TEST(SimCamera, DepthPixelsLandOnTheSignThroughTheCaptureConvention) {
  Rig rig(1, {2.0, 0.0, 0.0});
  rig.world.depth_noise = false;
  ASSERT_NEAR(rig.mission.robot.camera.depth_to_color_m.x(), 0.05, 1e-12);
  SimWorld& w = rig.make();
  w.advance(0.0);
  const DepthFrame f = *w.grab();
  // Capture's convention: p_camera = p_depth + depth_to_color_m, then the camera's pose.
  const Eigen::Isometry3d T_map_camera = w.true_T_map_camera();
  int on_sign = 0;
  for (int v = 0; v < f.height; v += 8) {
    for (int u = 0; u < f.width; u += 8) {
      if (f.at(u, v) == 0) continue;
      const Eigen::Vector3d p_depth =
          f.intrinsics.unproject(Eigen::Vector2d(u, v)) * f.at(u, v) * 1e-3;
      const Eigen::Vector3d p_map =
          T_map_camera * (p_depth + rig.mission.robot.camera.depth_to_color_m);
      if (std::abs(p_map.y()) < 0.15 && std::abs(p_map.z() - 0.9) < 0.1 && p_map.x() < 2.995) {
        // On the board's front face (x = 2.99) to within the 1 mm output step and quantisation.
        EXPECT_NEAR(p_map.x(), 2.99, 0.004) << u << "," << v;
        ++on_sign;
      }
    }
  }
  EXPECT_GT(on_sign, 50);
}

TEST(SimFaults, TargetMissingAndOccluder) {
  auto frame_with = [](std::vector<host::FaultSpec> faults) {
    Rig rig(1, {2.0, 0.0, 0.0});
    rig.world.faults = std::move(faults);
    rig.make().advance(0.0);
    return *rig.sim->grab();
  };
  const DepthFrame plain = frame_with({});
  const DepthFrame missing = frame_with({{"sign", "target_missing", {}, {}}});
  const DepthFrame occluded = frame_with(
      {{"sign", "occluder", {{"distance_m", 0.3}, {"width_m", 0.8}, {"height_m", 0.8}}, {}}});
  // The sign's pixels: about 1 m away where, without the sign, the view goes much deeper.
  auto sign_like = [&](const DepthFrame& f) {
    int n = 0;
    for (std::size_t i = 0; i < f.depth_mm.size(); ++i) {
      const int d = f.depth_mm[i], behind = missing.depth_mm[i];
      n += d >= 800 && d <= 1200 && (behind == 0 || behind - d > 300);
    }
    return n;
  };
  EXPECT_GT(sign_like(plain), 10000);
  EXPECT_EQ(sign_like(missing), 0);
  // The hanging board (0.3 m in front of the sign) hides it.
  EXPECT_LT(sign_like(occluded), sign_like(plain) / 20);
  EXPECT_GT(sign_pixels(occluded, 400, 700), 100000);
  EXPECT_LT(sign_pixels(plain, 400, 700), 1000);
}

TEST(SimFaults, FrameDropoutAndCameraDisconnect) {
  Rig rig(1, {2.0, 0.0, 0.0});
  rig.world.faults.push_back({"sign", "frame_dropout", {{"fraction", 1.0}}, {}});
  SimWorld& w = rig.make();
  w.advance(0.0);
  EXPECT_EQ(w.active_target(), "sign");
  auto f = w.grab();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->valid_count(), 0u);
  EXPECT_EQ(f->depth_mm.size(), 640u * 480u);
  // Away from the target the fault does not act.
  w.set_true_base_pose({-1.0, 0.0, kPi});
  rig.run_until(0.2);
  EXPECT_EQ(w.active_target(), "");
  f = w.grab();
  ASSERT_TRUE(f);
  EXPECT_GT(f->valid_count(), 1000u);

  Rig gone(1, {2.0, 0.0, 0.0});
  gone.world.faults.push_back({"sign", "camera_disconnect", {{"after_frames", 2}}, {}});
  SimWorld& g = gone.make();
  g.advance(0.0);
  EXPECT_TRUE(g.grab());
  gone.run_until(0.1);
  EXPECT_TRUE(g.grab());
  gone.run_until(0.2);
  EXPECT_THROW(g.grab(), DriverError);
}

// Regression: a fault on a revisit (a target on the same object as an earlier one) acted on the
// first target of that place instead, since the two are equally near the robot.
TEST(SimFaults, AFaultOnARevisitActsOnThatVisitOnly) {
  Rig rig(1, {2.0, 0.0, 0.0});
  rig.mission.targets.push_back(rig.mission.targets[0]);
  rig.mission.targets.back().id = "sign-again";
  rig.world.faults.push_back({"sign-again", "frame_dropout", {{"fraction", 1.0}}, {}});
  SimWorld& w = rig.make();
  ASSERT_EQ(&w.true_mesh("sign-again"), &w.true_mesh("sign"));
  // The valid pixels of the next frame, visiting `id` ("" = no visit named yet).
  const auto next_frame_pixels = [&](const std::string& id) -> std::size_t {
    if (!id.empty()) w.set_visited_target(id);
    rig.run_until(w.time_s() + 0.1);
    const auto frame = w.grab();
    return frame ? frame->valid_count() : 0u;
  };
  EXPECT_GT(next_frame_pixels(""), 1000u);
  EXPECT_EQ(w.active_target(), "sign");  // no visit named: the mission's first
  EXPECT_EQ(next_frame_pixels("sign-again"), 0u);
  EXPECT_EQ(w.active_target(), "sign-again");
  EXPECT_GT(next_frame_pixels("sign"), 1000u);
  EXPECT_EQ(w.active_target(), "sign");
  // An id the world does not know names no visit: the mission's first again.
  w.set_visited_target("no-such-target");
  EXPECT_EQ(w.active_target(), "sign");
}

TEST(SimFaults, KidnapOnArrival) {
  Rig rig(1, {1.0, 0.0, 0.0});
  rig.world.faults.push_back({"sign", "kidnap", {{"distance_m", 1.0}}, {}});
  SimWorld& w = rig.make();
  w.advance(0.0);
  w.command_velocity(0.5, 0.0);
  rig.run_until(2.0);  // arrives near x = 2 (the stand-off pose)
  w.command_velocity(0.0, 0.0);
  const Pose2D odo_before = w.odometry().pose;
  rig.run_until(3.0);
  const Pose2D truth = pose2d_from_isometry(w.true_T_map_base());
  // The truth jumped by about a metre; the odometry did not notice.
  EXPECT_NEAR(std::hypot(truth.x_m - odo_before.x_m, truth.y_m - odo_before.y_m), 1.0, 0.15);
  // Coasting to a stop adds a few centimetres, not a metre.
  EXPECT_NEAR(w.odometry().pose.x_m, odo_before.x_m, 0.1);
}

TEST(SimProjector, LogsShowsAndMotionAndInjectsFailure) {
  Rig rig(1, {2.0, 0.0, 0.0});
  SimWorld& w = rig.make();
  w.advance(0.0);
  const PinholeModel& k = rig.mission.robot.projector.intrinsics;
  const cv::Mat frame(k.height, k.width, CV_8UC3, cv::Scalar(0, 0, 255));
  EXPECT_TRUE(w.is_blank());
  w.show(frame);
  EXPECT_FALSE(w.is_blank());
  rig.run_until(1.0);
  EXPECT_EQ(w.lit_while_moving_s(), 0.0);
  w.command_velocity(0.2, 0.0);
  rig.run_until(2.0);
  EXPECT_GT(w.lit_while_moving_s(), 0.5);
  w.show(frame);
  w.blank();
  ASSERT_EQ(w.projector_log().size(), 3u);
  EXPECT_FALSE(w.projector_log()[0].base_moving);
  EXPECT_TRUE(w.projector_log()[1].base_moving);
  EXPECT_NEAR(w.projector_log()[1].t_s, 2.0, 1e-9);
  EXPECT_EQ(w.projector_log()[1].target, "sign");
  EXPECT_THROW(w.show(cv::Mat(10, 10, CV_8UC3)), std::invalid_argument);

  Rig failing(1, {2.0, 0.0, 0.0});
  failing.world.faults.push_back({"sign", "projector_failure", {{"after_shows", 1}}, {}});
  SimWorld& f = failing.make();
  f.advance(0.0);
  f.show(frame);
  EXPECT_THROW(f.show(frame), DriverError);
}

TEST(SimFaults, BlockedPathStopsTheBaseAndTheLaserSeesIt) {
  Rig rig(1, {0.5, 0.0, 0.0});
  rig.world.faults.push_back({"sign", "blocked_path", {{"size_m", 0.6}}, {}});
  SimWorld& w = rig.make();
  w.advance(0.0);
  const auto scan = w.take_scan();
  ASSERT_TRUE(scan);
  // Box face at x = 2 - 0.3 = 1.7; laser at x = 0.7.
  EXPECT_NEAR(scan->ranges_m[270], 1.0, 0.08);
  w.command_velocity(0.5, 0.0);
  rig.run_until(6.0);
  EXPECT_TRUE(w.base_blocked());
  EXPECT_LT(pose2d_from_isometry(w.true_T_map_base()).x_m, 1.7 - 0.1);
}

TEST(SimWorldTruth, ModelErrorAndTargetOffsetsAreSeededAndBounded) {
  auto world_with = [](std::uint64_t seed) {
    auto rig = std::make_unique<Rig>(seed);
    rig->mission.targets[0].model = std::string(PROJTOUR_SOURCE_DIR) + "/examples/models/bunny.ply";
    rig->world.model_error = true;
    rig->world.model_error_noise_mm = 1.0;
    rig->world.target_offset_max_m = 0.05;
    rig->world.target_offset_max_deg = 5.0;
    rig->make();
    return rig;
  };
  const auto a = world_with(1), b = world_with(1), c = world_with(2);
  const perception::TriangleMesh robot_copy = perception::load_mesh(a->mission.targets[0].model);
  const perception::TriangleMesh& seen = a->sim->true_mesh("sign");
  ASSERT_EQ(seen.vertices.size(), robot_copy.vertices.size());
  double sum2 = 0.0, max_m = 0.0;
  for (std::size_t i = 0; i < seen.vertices.size(); ++i) {
    const double d = (seen.vertices[i] - robot_copy.vertices[i]).norm();
    sum2 += d * d;
    max_m = std::max(max_m, d);
  }
  // About 1 mm RMS, smooth (no vertex far out).
  EXPECT_NEAR(std::sqrt(sum2 / seen.vertices.size()) * 1000.0, 1.0, 0.05);
  EXPECT_LT(max_m * 1000.0, 4.0);
  EXPECT_EQ(b->sim->true_mesh("sign").vertices, seen.vertices);
  EXPECT_NE(c->sim->true_mesh("sign").vertices, seen.vertices);
  // The true pose: nominal moved within the bounds, the same for the same seed.
  const Eigen::Isometry3d nominal = a->mission.targets[0].T_map_model;
  const Eigen::Isometry3d truth = a->sim->true_T_map_model("sign");
  EXPECT_LE(translation_distance_m(truth, nominal), 0.05 + 1e-9);
  EXPECT_LE(rad_to_deg(rotation_angle_rad(truth, nominal)), 5.0 + 1e-9);
  EXPECT_GT(translation_distance_m(truth, nominal), 0.0);
  EXPECT_TRUE(b->sim->true_T_map_model("sign").isApprox(truth));
  EXPECT_FALSE(c->sim->true_T_map_model("sign").isApprox(truth));
  // A pose listed in the world file wins.
  Rig listed;
  listed.world.T_map_model_true["sign"] = isometry_from_xyz_rpy(3.01, 0.02, 0.9, 0, 0, 3.1);
  listed.world.target_offset_max_m = 0.05;
  listed.make();
  EXPECT_TRUE(listed.sim->true_T_map_model("sign").isApprox(
      isometry_from_xyz_rpy(3.01, 0.02, 0.9, 0, 0, 3.1)));
}

// A long day visits the same object again and again: before, every visit was a copy of its own
// (0.7 MB of meshes and BVHs per target in a 200-target mission).
TEST(SimWorldTruth, TargetsOnOneModelAndPoseAreOneObjectVisitedAgain) {
  Rig rig(1, {2.0, 0.0, 0.0});
  rig.world.model_error = true;
  rig.world.model_error_noise_mm = 1.0;
  const TargetSpec sign = rig.mission.targets[0];
  for (const char* id : {"sign-again", "sign-missing", "sign-nudged"}) {
    rig.mission.targets.push_back(sign);
    rig.mission.targets.back().id = id;
  }
  rig.mission.targets.push_back(sign);
  rig.mission.targets.back().id = "sign-beside";
  rig.mission.targets.back().T_map_model.translation().y() += 1.0;
  rig.world.faults = {{"sign-missing", "target_missing", {}, {}},
                      {"sign-nudged", "target_nudge", {{"distance_m", 0.02}}, {}}};
  SimWorld& w = rig.make();
  const perception::TriangleMesh& first = w.true_mesh("sign");
  EXPECT_EQ(&w.true_mesh("sign-again"), &first);
  EXPECT_NE(&w.true_mesh("sign-missing"), &first);
  EXPECT_NE(&w.true_mesh("sign-nudged"), &first);
  EXPECT_NE(&w.true_mesh("sign-beside"), &first);
  // Each object has a surface of its own (its own perturbation), the revisit the same one.
  EXPECT_NE(w.true_mesh("sign-beside").vertices, first.vertices);
  EXPECT_TRUE(w.true_T_map_model("sign-again").isApprox(w.true_T_map_model("sign")));
  // The referee answers for a revisit as for the first visit.
  w.advance(0.0);
  aim_at_sign(rig, w);
  const auto px = true_pixels(rig, w);
  const auto first_visit = w.evaluate_projection("sign", px);
  const auto revisit = w.evaluate_projection("sign-again", px);
  ASSERT_TRUE(first_visit && revisit);
  EXPECT_EQ(first_visit->error_mm, revisit->error_mm);
  EXPECT_LT(first_visit->mean_mm(), 5.0);
}

TEST(SimPlugin, ProvidesFiveDriversSharingOneWorld) {
  host::PluginRegistry registry;
  registry.load_library(std::filesystem::path(PROJTOUR_PLUGIN_BUILD_DIR) / "libprojtour_sim.so");
  Rig rig(1, {2.0, 0.0, 0.0});
  rig.run.run_dir = testing::test_temp_path("run");
  std::filesystem::remove_all(rig.run.run_dir);
  std::vector<std::shared_ptr<Driver>> drivers;
  for (const char* kind :
       {"sim_base", "sim_laser", "sim_pan_tilt", "sim_depth_camera", "sim_projector"}) {
    const host::KindInfo& info = registry.require(kind);
    EXPECT_EQ(info.family, host::Family::driver);
    drivers.push_back(registry.create_driver(kind, host::default_params(info.params), rig.run));
    ASSERT_TRUE(drivers.back());
  }
  GroundTruth* truth = drivers[0]->ground_truth();
  ASSERT_NE(truth, nullptr);
  for (const auto& d : drivers) EXPECT_EQ(d->ground_truth(), truth);
  auto base = std::dynamic_pointer_cast<BaseDriver>(drivers[0]);
  ASSERT_TRUE(base);
  for (const auto& d : drivers) d->update(0.0);
  base->command_velocity(0.2, 0.0);
  for (int k = 1; k <= 10; ++k) {
    for (const auto& d : drivers) d->update(0.1 * k);  // every driver, same t: one step
  }
  EXPECT_NEAR(truth->true_T_map_base().translation().x(), 2.0 + 0.2 * 1.0, 0.05);
  // The projector's log goes to the run directory, one JSON object a line.
  auto projector = std::dynamic_pointer_cast<ProjectorDriver>(drivers[4]);
  ASSERT_TRUE(projector);
  projector->blank();
  std::ifstream log(rig.run.run_dir / "sim_projector_log.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(log, line));
  EXPECT_NE(line.find("\"event\": \"blank\""), std::string::npos) << line;
  EXPECT_NE(line.find("\"base_moving\": true"), std::string::npos) << line;
}

}  // namespace
}  // namespace projtour::sim
