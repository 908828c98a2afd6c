#include "projtour_test/geometry_rig.hpp"

#include <opencv2/imgcodecs.hpp>

#include "projtour/head/kinematics.hpp"
#include "projtour/host/params_reader.hpp"

namespace projtour::geometry_test {

void FakeProjector::show(const cv::Mat& frame_bgr) {
  frames.push_back(frame_bgr.clone());
  blank_ = false;
}

void FakePanTilt::update(double) {
  if (remaining_ticks_ > 0 && --remaining_ticks_ == 0) measured_ = commands.back();
}

void FakePanTilt::command(const JointAngles& angles) {
  commands.push_back(angles);
  projector_blank_at_command.push_back(projector_ == nullptr || projector_->is_blank());
  remaining_ticks_ = ticks_to_reach;
  if (remaining_ticks_ == 0) measured_ = angles;
}

PinholeModel ud_projector_intrinsics() {
  PinholeModel m;
  m.width = 1280;
  m.height = 800;
  m.fx = m.fy = 1920.0;
  m.cx = 640.0;
  m.cy = 400.0;
  m.distortion = {0.01, -0.005, 0.0, 0.0, 0.0};
  return m;
}

RobotSpec ud_like_robot() {
  RobotSpec r;
  r.name = "ud-test";
  r.base.radius_m = 0.3;
  r.pan_tilt.T_base_pan0 = isometry_from_xyz_rpy(0.02, 0.01, 1.0, 0, 0, 0);
  r.pan_tilt.T_pan_tilt0 = isometry_from_xyz_rpy(0.03, 0.04, 0.1, 0, 0, 0);
  r.camera.mount.link = Link::pan;
  r.camera.mount.T_link_body = isometry_from_xyz_rpy(0.08, 0.0, 0.25, 0, deg_to_rad(20), 0);
  r.camera.intrinsics.width = 640;
  r.camera.intrinsics.height = 480;
  r.camera.intrinsics.fx = r.camera.intrinsics.fy = 525;
  r.camera.intrinsics.cx = 319.5;
  r.camera.intrinsics.cy = 239.5;
  r.projector.mount.link = Link::tilt;
  r.projector.mount.T_link_body = isometry_from_xyz_rpy(0.1, -0.05, 0.02, 0, 0, 0);
  r.projector.intrinsics = ud_projector_intrinsics();
  r.pan_tilt.stow_pan_deg = 0;
  r.pan_tilt.stow_tilt_deg = 10;
  return r;
}

TargetSpec wall_target(const std::string& id, double x_m, double y_m) {
  TargetSpec t;
  t.id = id;
  t.T_map_model = isometry_from_xyz_rpy(x_m, y_m, 0.9, 0, 0, kPi);
  t.model_points = {Eigen::Vector3d(0.0, 0.20, 0.125), Eigen::Vector3d(0.0, -0.20, 0.125),
                    Eigen::Vector3d(0.0, -0.20, -0.125), Eigen::Vector3d(0.0, 0.20, -0.125)};
  t.dwell_s = 2.0;
  return t;
}

std::filesystem::path write_quadrant_content(const std::filesystem::path& dir) {
  cv::Mat content(500, 800, CV_8UC3);
  content(cv::Rect(0, 0, 400, 250)).setTo(cv::Scalar(0, 0, 255));
  content(cv::Rect(400, 0, 400, 250)).setTo(cv::Scalar(0, 255, 0));
  content(cv::Rect(400, 250, 400, 250)).setTo(cv::Scalar(255, 0, 0));
  content(cv::Rect(0, 250, 400, 250)).setTo(cv::Scalar(255, 255, 255));
  const std::filesystem::path file = dir / "quadrants.png";
  cv::imwrite(file.string(), content);
  return file;
}

Rig::Rig() {
  mission.name = "geometry-test";
  mission.robot = ud_like_robot();
  mission.targets = {wall_target("front", 3.0, 0.0), wall_target("left", 1.0, 4.0),
                     wall_target("far", 8.0, -1.0)};
  const auto content = write_quadrant_content(dir);
  for (auto& t : mission.targets) t.content = content;
  projector = std::make_shared<FakeProjector>();
  pan_tilt = std::make_shared<FakePanTilt>(projector.get());
  drivers.projector = projector;
  drivers.pan_tilt = pan_tilt;
  // Warnings are what some tests look for; only errors go to stderr.
  ctx = rig.context(&params);
  set_target(0);
  for (const char* name : {"aim", "project", "next", "projector", "ptu_dperception"}) {
    registry.load_library(std::filesystem::path(PROJTOUR_PLUGIN_BUILD_DIR) /
                          ("libprojtour_" + std::string(name) + ".so"));
  }
}

void Rig::set_target(std::size_t index) {
  ctx = rig.target_context(index, &params);
}

std::shared_ptr<Behaviour> Rig::make(const std::string& kind,
                                     const std::map<std::string, ParamValue>& overrides) {
  const host::KindInfo& info = registry.require(kind);
  auto p = std::make_unique<Params>(host::default_params(info.params));
  for (const auto& [name, value] : overrides) p->set(name, value);
  const std::string why = registry.validate_params(kind, *p);
  if (!why.empty()) throw std::invalid_argument(why);
  auto b = registry.create_behaviour(kind, *p, run_ctx);
  params_keep.push_back(std::move(p));
  return b;
}

Outcome Rig::run(Behaviour& b, double dt_s, int max_ticks) {
  b.start(ctx);
  for (int i = 0; i < max_ticks; ++i) {
    if (i == ticks_before_cancel) cancel.request();
    clock.advance(dt_s);
    for (const auto& d : drivers.all()) d->update(clock.now_s());
    if (auto outcome = b.tick(ctx)) {
      b.stop(ctx);
      return *outcome;
    }
  }
  b.stop(ctx);
  return Outcome{"timeout", "no outcome"};
}

Eigen::Isometry3d Rig::exact_T_camera_model(const Pose2D& base, const TargetSpec& target) const {
  const head::HeadKinematics k(mission.robot);
  const Eigen::Isometry3d T_map_camera =
      isometry_from_pose2d(base) * k.T_base_camera(pan_tilt->measured());
  return T_map_camera.inverse() * target.T_map_model;
}

}  // namespace projtour::geometry_test
