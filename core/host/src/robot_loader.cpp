// The robot file (format documented in examples/robot/ud.yaml).
#include "loader_fields.hpp"
#include "projtour/mission_loader.hpp"

namespace projtour {

namespace {

using loader::format_number;
using loader::read_angle_deg;
using loader::read_integer;
using loader::read_number;
using loader::Sign;

// Larger images are a typo (or an overflow waiting to happen in int pixel arithmetic).
constexpr long long kMaxImageSide = 16384;

void read_base(const YamlField& f, BaseSpec& base) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"radius_m", "max_speed_mps", "max_turn_rate_dps"});
  if (auto v = read_number(f["radius_m"], true, Sign::positive)) base.radius_m = *v;
  if (auto v = read_number(f["max_speed_mps"], false, Sign::positive)) base.max_speed_mps = *v;
  if (auto v = read_number(f["max_turn_rate_dps"], false, Sign::positive)) {
    base.max_turn_rate_dps = *v;
  }
}

void read_laser(const YamlField& f, LaserSpec& laser) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"pose", "fov_deg", "rays", "max_range_m", "range_noise_m", "rate_hz"});
  if (auto T = loader::read_pose(f["pose"])) laser.T_base_laser = *T;
  if (auto v = read_number(f["fov_deg"], false, Sign::positive)) {
    if (*v > 360.0) {
      f["fov_deg"].error("expected a field of view within (0, 360] degrees, got " +
                         format_number(*v));
    } else {
      laser.fov_deg = *v;
    }
  }
  if (auto v = read_integer(f["rays"], false, Sign::positive)) {
    if (*v < 2 || *v > 100000) {
      f["rays"].error("expected between 2 and 100000 rays, got " + std::to_string(*v));
    } else {
      laser.rays = static_cast<int>(*v);
    }
  }
  if (auto v = read_number(f["max_range_m"], false, Sign::positive)) laser.max_range_m = *v;
  if (auto v = read_number(f["range_noise_m"], false, Sign::non_negative)) {
    laser.range_noise_m = *v;
  }
  if (auto v = read_number(f["rate_hz"], false, Sign::positive)) laser.rate_hz = *v;
}

std::optional<Eigen::Isometry3d> read_joint(const YamlField& f) {
  if (!f.expect_map()) return std::nullopt;
  loader::check_keys(f, {"pose"});
  return loader::read_pose(f["pose"]);
}

// [min, max] in degrees, min < max.
bool read_limits(const YamlField& f, double& min_deg, double& max_deg) {
  const auto limits = loader::read_numbers<2>(f, true, "[min, max]");
  if (!limits) return false;
  const auto [lo, hi] = *limits;
  if (lo < -360.0 || hi > 360.0 || !(lo < hi)) {
    f.error("expected [min, max] with -360 <= min < max <= 360, got [" + format_number(lo) + ", " +
            format_number(hi) + "]");
    return false;
  }
  min_deg = lo;
  max_deg = hi;
  return true;
}

void read_stow_angle(const YamlField& f, bool limits_ok, double min_deg, double max_deg,
                     const std::string& limits_name, double& out) {
  const auto v = read_angle_deg(f, false);
  if (!v) return;
  if (limits_ok && (*v < min_deg || *v > max_deg)) {
    f.error("stow angle " + format_number(*v) + " lies outside " + limits_name + " [" +
            format_number(min_deg) + ", " + format_number(max_deg) + "]");
    return;
  }
  out = *v;
}

void read_pan_tilt(const YamlField& f, PanTiltSpec& pt) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"pan_joint", "tilt_joint", "pan_limits_deg", "tilt_limits_deg",
                         "max_rate_dps", "encoder_noise_deg", "stow", "tolerance_deg"});
  if (auto T = read_joint(f["pan_joint"])) pt.T_base_pan0 = *T;
  if (auto T = read_joint(f["tilt_joint"])) pt.T_pan_tilt0 = *T;
  const bool pan_ok = read_limits(f["pan_limits_deg"], pt.pan_min_deg, pt.pan_max_deg);
  const bool tilt_ok = read_limits(f["tilt_limits_deg"], pt.tilt_min_deg, pt.tilt_max_deg);
  if (auto v = read_number(f["max_rate_dps"], false, Sign::positive)) pt.max_rate_dps = *v;
  if (auto v = read_number(f["encoder_noise_deg"], false, Sign::non_negative)) {
    pt.encoder_noise_deg = *v;
  }
  if (auto v = read_number(f["tolerance_deg"], false, Sign::positive)) pt.tolerance_deg = *v;
  const YamlField stow = f["stow"];
  if (stow.expect_map(false)) {
    loader::check_keys(stow, {"pan_deg", "tilt_deg"});
    read_stow_angle(stow["pan_deg"], pan_ok, pt.pan_min_deg, pt.pan_max_deg, "pan_limits_deg",
                    pt.stow_pan_deg);
    read_stow_angle(stow["tilt_deg"], tilt_ok, pt.tilt_min_deg, pt.tilt_max_deg, "tilt_limits_deg",
                    pt.stow_tilt_deg);
  }
}

void read_mount(const YamlField& f, MountSpec& mount) {
  if (auto link = f["mount"].as_enum({"pan", "tilt"})) {
    mount.link = *link == "pan" ? Link::pan : Link::tilt;
  }
  if (auto T = loader::read_pose(f["pose"])) mount.T_link_body = *T;
}

std::optional<int> read_image_side(const YamlField& f) {
  const auto v = read_integer(f, true, Sign::positive);
  if (!v) return std::nullopt;
  if (*v > kMaxImageSide) {
    f.error("expected at most " + std::to_string(kMaxImageSide) + " pixels, got " +
            std::to_string(*v));
    return std::nullopt;
  }
  return static_cast<int>(*v);
}

// width, height, fx, fy, cx, cy (the principal point inside the image).
void read_intrinsics(const YamlField& f, PinholeModel& model) {
  const auto width = read_image_side(f["width"]);
  const auto height = read_image_side(f["height"]);
  const auto fx = read_number(f["fx"], true, Sign::positive);
  const auto fy = read_number(f["fy"], true, Sign::positive);
  const auto cx = read_number(f["cx"], true);
  const auto cy = read_number(f["cy"], true);
  if (width) model.width = *width;
  if (height) model.height = *height;
  if (fx) model.fx = *fx;
  if (fy) model.fy = *fy;
  if (cx) {
    if (width && (*cx < 0.0 || *cx > *width)) {
      f["cx"].error("principal point x " + format_number(*cx) + " lies outside the image [0, " +
                    std::to_string(*width) + "]");
    }
    model.cx = *cx;
  }
  if (cy) {
    if (height && (*cy < 0.0 || *cy > *height)) {
      f["cy"].error("principal point y " + format_number(*cy) + " lies outside the image [0, " +
                    std::to_string(*height) + "]");
    }
    model.cy = *cy;
  }
}

void read_camera(const YamlField& f, CameraSpec& camera) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"mount", "pose", "width", "height", "fx", "fy", "cx", "cy",
                         "depth_to_color_m", "min_range_m", "max_range_m", "rate_hz"});
  read_mount(f, camera.mount);
  read_intrinsics(f, camera.intrinsics);
  if (auto v = loader::read_numbers<3>(f["depth_to_color_m"], false, "[x, y, z]")) {
    camera.depth_to_color_m = Eigen::Vector3d((*v)[0], (*v)[1], (*v)[2]);
  }
  const auto min_range = read_number(f["min_range_m"], false, Sign::non_negative);
  const auto max_range = read_number(f["max_range_m"], false, Sign::positive);
  if (min_range) camera.min_range_m = *min_range;
  if (max_range) camera.max_range_m = *max_range;
  if ((min_range || max_range) && !(camera.min_range_m < camera.max_range_m)) {
    f[max_range ? "max_range_m" : "min_range_m"].error("expected min_range_m < max_range_m, got " +
                                                       format_number(camera.min_range_m) + " and " +
                                                       format_number(camera.max_range_m));
  }
  if (auto v = read_number(f["rate_hz"], false, Sign::positive)) camera.rate_hz = *v;
}

void read_projector(const YamlField& f, ProjectorSpec& projector) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"mount", "pose", "width", "height", "fx", "fy", "cx", "cy", "distortion"});
  read_mount(f, projector.mount);
  read_intrinsics(f, projector.intrinsics);
  if (auto d = loader::read_numbers<5>(f["distortion"], false, "[k1, k2, p1, p2, k3]")) {
    projector.intrinsics.distortion = *d;
  }
}

void read_instances(const YamlField& f, const std::vector<std::string>& roles,
                    std::map<std::string, PluginInstanceSpec>& out) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, roles);
  for (const auto& role : roles) {
    const YamlField entry = f[role];
    if (!entry.defined()) continue;
    if (auto spec = loader::read_plugin_instance(entry)) out[role] = std::move(*spec);
  }
}

std::optional<LoadedRobot> read_robot(const YAML::Node& node, const std::string& file,
                                      Diagnostics& diag) {
  const std::size_t errors_before = diag.error_count();
  const YamlField root(node, file, diag);
  if (!root.defined()) {
    root.error(
        "empty robot file: expected a mapping with robot, base, laser, pan_tilt, camera "
        "and projector");
    return std::nullopt;
  }
  if (!root.expect_map()) return std::nullopt;
  loader::check_keys(
      root, {"robot", "base", "laser", "pan_tilt", "camera", "projector", "drivers", "services"});

  LoadedRobot robot;
  robot.file = file;
  if (auto name = root["robot"].as_string()) robot.name = *name;
  read_base(root["base"], robot.base);
  read_laser(root["laser"], robot.laser);
  read_pan_tilt(root["pan_tilt"], robot.pan_tilt);
  read_camera(root["camera"], robot.camera);
  read_projector(root["projector"], robot.projector);
  read_instances(root["drivers"],
                 {"base", "laser", "pan_tilt", "depth_camera", "projector", "colour_camera"},
                 robot.drivers);
  const YamlField services = root["services"];
  read_instances(services, {"localization"}, robot.services);
  if (!robot.services.count("localization")) {
    // Localization runs on every tour, so a robot file need not spell out the usual one.
    PluginInstanceSpec localization;
    localization.kind = "mrpt_localization";
    localization.params = YAML::Node(YAML::NodeType::Undefined);
    localization.params_path = services.child_path("localization") + ".params";
    localization.mark = services.mark();
    robot.services["localization"] = std::move(localization);
  }

  if (diag.error_count() > errors_before) return std::nullopt;
  return robot;
}

}  // namespace

std::optional<LoadedRobot> load_robot(const std::filesystem::path& file, Diagnostics& diag) {
  const auto node = load_yaml_file(file, diag);
  if (!node) return std::nullopt;
  return read_robot(*node, file.string(), diag);
}

}  // namespace projtour
