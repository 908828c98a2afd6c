// The robot file (format documented in examples/robot/ud.yaml).
#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "loader_fields.hpp"
#include "projtour/host/mission_loader.hpp"

namespace projtour::host {

namespace {

using loader::format_number;
using loader::read_angle_deg;
using loader::read_integer;
using loader::read_number;
using loader::Sign;

// Larger images are a typo: twice an 8K sensor's width, and a depth frame of 8192x8192 is already
// a quarter of a gigabyte a frame (and 16384 sides overflow int pixel arithmetic).
constexpr long long kMaxImageSide = 8192;

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

std::optional<int> read_image_side(const YamlField& f, bool required) {
  const auto v = read_integer(f, required, Sign::positive);
  if (!v) return std::nullopt;
  if (*v > kMaxImageSide) {
    f.error("expected at most " + std::to_string(kMaxImageSide) + " pixels, got " +
            std::to_string(*v));
    return std::nullopt;
  }
  return static_cast<int>(*v);
}

// What a field of a model stands at after reading: the value read; for an optional field left
// out, the model's default; nullopt when it was required or written wrong (reported already),
// so no check builds on it.
template <typename T>
std::optional<T> effective(const YamlField& f, const std::optional<T>& read, bool required,
                           T fallback) {
  if (read) return read;
  if (!required && !f.defined()) return fallback;
  return std::nullopt;
}

// The principal point along one axis inside [0, side]. With optional fields a default can meet
// a written value, so the check runs when either was written and is reported at the one written
// (the point when both were).
void check_principal_point(const YamlField& f, const std::string& point_key,
                           const std::string& side_key, const char* axis,
                           const std::optional<double>& point, const std::optional<int>& side) {
  if (!point || !side) return;
  const YamlField point_field = f[point_key];
  const YamlField side_field = f[side_key];
  if (!point_field.defined() && !side_field.defined()) return;
  if (*point >= 0.0 && *point <= *side) return;
  const std::string by_default = point_field.defined() ? "" : " (" + point_key + "'s default)";
  (point_field.defined() ? point_field : side_field)
      .error(std::string("principal point ") + axis + " " + format_number(*point) + by_default +
             " lies outside the image [0, " + std::to_string(*side) + "]");
}

// width, height, fx, fy, cx, cy (the principal point inside the image). Where not `required`,
// a field left out keeps the model's value.
void read_intrinsics(const YamlField& f, PinholeModel& model, bool required = true) {
  const auto width =
      effective(f["width"], read_image_side(f["width"], required), required, model.width);
  const auto height =
      effective(f["height"], read_image_side(f["height"], required), required, model.height);
  const auto fx = read_number(f["fx"], required, Sign::positive);
  const auto fy = read_number(f["fy"], required, Sign::positive);
  const auto cx = effective(f["cx"], read_number(f["cx"], required), required, model.cx);
  const auto cy = effective(f["cy"], read_number(f["cy"], required), required, model.cy);
  check_principal_point(f, "cx", "width", "x", cx, width);
  check_principal_point(f, "cy", "height", "y", cy, height);
  if (width) model.width = *width;
  if (height) model.height = *height;
  if (fx) model.fx = *fx;
  if (fy) model.fy = *fy;
  if (cx) model.cx = *cx;
  if (cy) model.cy = *cy;
}

void read_distortion(const YamlField& f, PinholeModel& model) {
  if (auto d = loader::read_numbers<5>(f, false, "[k1, k2, p1, p2, k3]")) model.distortion = *d;
}

// Every field optional: the defaults are the Kinect v1's colour camera.
void read_colour_camera(const YamlField& f, ColourCameraSpec& colour) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, {"width", "height", "fx", "fy", "cx", "cy", "distortion", "rate_hz"});
  read_intrinsics(f, colour.intrinsics, false);
  read_distortion(f["distortion"], colour.intrinsics);
  if (auto v = read_number(f["rate_hz"], false, Sign::positive)) colour.rate_hz = *v;
}

void read_camera(const YamlField& f, CameraSpec& camera) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"mount", "pose", "width", "height", "fx", "fy", "cx", "cy",
                         "depth_to_color_m", "min_range_m", "max_range_m", "rate_hz", "colour"});
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
  read_colour_camera(f["colour"], camera.colour);
}

void read_projector(const YamlField& f, ProjectorSpec& projector) {
  if (!f.expect_map()) return;
  loader::check_keys(f, {"mount", "pose", "width", "height", "fx", "fy", "cx", "cy", "distortion"});
  read_mount(f, projector.mount);
  read_intrinsics(f, projector.intrinsics);
  read_distortion(f["distortion"], projector.intrinsics);
}

std::optional<long long> read_integer_at_least(const YamlField& f, long long least) {
  const auto v = f.as_int(false);
  if (!v) return std::nullopt;
  if (*v < least) {
    f.error("expected an integer >= " + std::to_string(least) + ", got " + f.node().Scalar());
    return std::nullopt;
  }
  return v;
}

// The calibrate step's Gray-code settings; `projector` bounds the block (when it was read).
void read_structured_light(const YamlField& f, const PinholeModel& projector,
                           StructuredLightSpec& light) {
  if (!f.expect_map(false)) return;
  loader::check_keys(
      f, {"block_px", "hold_s", "exposure_ms", "min_correspondences", "max_residual_px"});
  // At least 2: camera and projector travel together, so a projector pixel covers the same part
  // of a colour pixel at every distance (about a quarter on the UD) and one-pixel stripes never
  // resolve.
  if (auto v = read_integer_at_least(f["block_px"], 2)) {
    const int smaller_side = std::min(projector.width, projector.height);
    if (smaller_side > 0 && *v > smaller_side) {
      // No stripe fits: the sequence would code nothing along that axis.
      f["block_px"].error("block of " + std::to_string(*v) + " px does not fit the projector's " +
                          std::to_string(projector.width) + "x" + std::to_string(projector.height) +
                          " image");
    } else {
      light.block_px = static_cast<int>(*v);
    }
  }
  if (auto v = read_number(f["hold_s"], false, Sign::positive)) light.hold_s = *v;
  if (auto v = read_number(f["exposure_ms"], false, Sign::non_negative)) light.exposure_ms = *v;
  // Six: the fewest points OpenCV's default PnP (initialised by a DLT) takes in general position.
  if (auto v = read_integer_at_least(f["min_correspondences"], 6)) {
    light.min_correspondences = static_cast<int>(*v);
  }
  if (auto v = read_number(f["max_residual_px"], false, Sign::positive)) {
    light.max_residual_px = *v;
  }
}

// ROS 2's name rules (design.ros2.org "Topic and Service name mapping"): tokens of letters,
// digits and underscores, not starting with a digit, joined by single slashes.
std::optional<std::string> ros2_name_problem(const std::string& name, bool absolute_allowed) {
  if (name.empty()) return "is empty";
  std::string rest = name;
  if (rest.front() == '/') {
    if (!absolute_allowed) return "must not start with '/'";
    rest.erase(0, 1);
    if (rest.empty()) return "is only '/'";
  }
  std::size_t start = 0;
  while (start <= rest.size()) {
    const std::size_t end = std::min(rest.find('/', start), rest.size());
    const std::string token = rest.substr(start, end - start);
    if (token.empty()) return "has an empty token (a doubled or trailing '/')";
    if (std::isdigit(static_cast<unsigned char>(token.front()))) {
      return "has a token starting with a digit (\"" + token + "\")";
    }
    for (char c : token) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
        return std::string("has the character '") + c + "' (only letters, digits, '_' and '/')";
      }
    }
    start = end + 1;
  }
  return std::nullopt;
}

void read_ros2_name(const YamlField& f, bool absolute_allowed, std::string& out) {
  if (!f.defined()) return;
  auto v = f.as_string();
  if (!v) return;
  if (auto problem = ros2_name_problem(*v, absolute_allowed)) {
    f.error("expected a ROS 2 name; \"" + *v + "\" " + *problem);
    return;
  }
  out = *v;
}

// A topic is its name alone, or {name, reliability, depth} to change ROS 2's QoS default.
void read_ros2_topic(const YamlField& f, Ros2TopicSpec& topic) {
  if (!f.defined()) return;
  if (f.is_scalar()) {
    read_ros2_name(f, true, topic.name);
    return;
  }
  if (!f.expect_map()) return;
  loader::check_keys(f, {"name", "reliability", "depth"});
  read_ros2_name(f["name"], true, topic.name);
  if (auto r = f["reliability"].as_enum({"reliable", "best_effort"}, false)) {
    topic.reliable = *r == "reliable";
  }
  if (auto d = f["depth"].as_int(false)) {
    if (*d < 1 || *d > 1000) {
      f["depth"].error("expected a keep-last depth from 1 to 1000, got " + std::to_string(*d));
    } else {
      topic.depth = static_cast<int>(*d);
    }
  }
}

// ROS 2's environment is the default for what the robot file leaves out: ROS_DOMAIN_ID, and
// ROS_LOCALHOST_ONLY=1 for loopback only.
void read_ros2_environment(const YamlField& f, Ros2Spec& ros2) {
  if (const char* id = std::getenv("ROS_DOMAIN_ID"); id != nullptr && *id != '\0') {
    char* end = nullptr;
    const long v = std::strtol(id, &end, 10);
    if (*end != '\0' || v < 0 || v > 232) {
      f.error(std::string("environment variable ROS_DOMAIN_ID=\"") + id +
              "\": expected a DDS domain id from 0 to 232");
    } else {
      ros2.domain_id = static_cast<int>(v);
    }
  }
  if (const char* local = std::getenv("ROS_LOCALHOST_ONLY")) {
    ros2.loopback_only = std::string(local) == "1";
  }
}

void read_ros2(const YamlField& f, Ros2Spec& ros2) {
  read_ros2_environment(f, ros2);
  if (!f.defined()) return;
  if (!f.expect_map()) return;
  ros2.present = true;
  loader::check_keys(f, {"domain_id", "namespace", "loopback_only", "topics", "frames", "joints",
                         "odom_timeout_s", "stop_repeats", "publish_status"});
  if (auto d = f["domain_id"].as_int(false)) {
    // ROS 2's range: Cyclone maps a domain to UDP ports 7400 + 250 * id, past 65535 above 232.
    if (*d < 0 || *d > 232) {
      f["domain_id"].error("expected a DDS domain id from 0 to 232, got " + std::to_string(*d));
    } else {
      ros2.domain_id = static_cast<int>(*d);
    }
  }
  if (f["namespace"].defined()) {
    const YamlField ns = f["namespace"];
    if (auto v = ns.as_string()) {
      if (!v->empty()) {
        if (v->front() != '/') {
          ns.error("expected a namespace starting with '/' (or \"\"), got \"" + *v + "\"");
        } else if (auto problem = ros2_name_problem(*v, true)) {
          ns.error("expected a ROS 2 namespace; \"" + *v + "\" " + *problem);
        } else {
          ros2.ros2_namespace = *v;
        }
      }
    }
  }
  if (auto v = f["loopback_only"].as_bool(false)) ros2.loopback_only = *v;
  const YamlField topics = f["topics"];
  if (topics.expect_map(false)) {
    loader::check_keys(topics, {"cmd_vel", "odom", "scan", "joint_states", "pan_tilt_command"});
    read_ros2_topic(topics["cmd_vel"], ros2.cmd_vel);
    read_ros2_topic(topics["odom"], ros2.odom);
    read_ros2_topic(topics["scan"], ros2.scan);
    read_ros2_topic(topics["joint_states"], ros2.joint_states);
    read_ros2_topic(topics["pan_tilt_command"], ros2.pan_tilt_command);
  }
  const YamlField frames = f["frames"];
  if (frames.expect_map(false)) {
    loader::check_keys(frames, {"odom", "base", "laser"});
    read_ros2_name(frames["odom"], false, ros2.odom_frame);
    read_ros2_name(frames["base"], false, ros2.base_frame);
    read_ros2_name(frames["laser"], false, ros2.laser_frame);
  }
  const YamlField joints = f["joints"];
  if (joints.expect_map(false)) {
    loader::check_keys(joints, {"pan", "tilt"});
    read_ros2_name(joints["pan"], false, ros2.pan_joint);
    read_ros2_name(joints["tilt"], false, ros2.tilt_joint);
    if (ros2.pan_joint == ros2.tilt_joint) {
      joints.error("pan and tilt must be different joints, both are \"" + ros2.pan_joint + "\"");
    }
  }
  if (auto v = read_number(f["odom_timeout_s"], false, Sign::positive)) ros2.odom_timeout_s = *v;
  if (auto v = read_integer_at_least(f["stop_repeats"], 1)) {
    ros2.stop_repeats = static_cast<int>(std::min<long long>(*v, 100));
  }
  if (auto v = f["publish_status"].as_bool(false)) ros2.publish_status = *v;
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
  loader::check_keys(root, {"robot", "base", "laser", "pan_tilt", "camera", "projector",
                            "structured_light", "ros2", "drivers", "services"});

  LoadedRobot robot;
  robot.file = file;
  if (auto name = root["robot"].as_string()) robot.name = *name;
  read_base(root["base"], robot.base);
  read_laser(root["laser"], robot.laser);
  read_pan_tilt(root["pan_tilt"], robot.pan_tilt);
  read_camera(root["camera"], robot.camera);
  read_projector(root["projector"], robot.projector);
  read_structured_light(root["structured_light"], robot.projector.intrinsics,
                        robot.structured_light);
  read_ros2(root["ros2"], robot.ros2);
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

}  // namespace projtour::host
