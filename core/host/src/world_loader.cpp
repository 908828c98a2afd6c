// The world file of a dry run (format documented in examples/worlds/atrium_faults.yaml).
#include <algorithm>

#include "loader_fields.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/world_faults.hpp"

namespace projtour::host {

namespace {

using loader::read_number;
using loader::Sign;

// The fault types in the table's order: the order an unknown type's diagnostic lists them in.
std::vector<std::string> fault_type_names() {
  std::vector<std::string> names;
  for (const FaultKindSpec& kind : fault_kinds()) names.push_back(kind.type);
  return names;
}

Sign loader_sign(FaultNumberSign sign) {
  switch (sign) {
    case FaultNumberSign::positive:
      return Sign::positive;
    case FaultNumberSign::non_negative:
      return Sign::non_negative;
    case FaultNumberSign::any:
      break;
  }
  return Sign::any;
}

std::vector<std::string> target_ids(const MissionSpec& mission) {
  std::vector<std::string> ids;
  for (const auto& t : mission.targets) ids.push_back(t.id);
  return ids;
}

// A target id of the mission; `where` is the field or key holding it.
bool check_target_id(const std::string& id, const MissionSpec& mission, const SourceMark& mark,
                     const std::string& where, Diagnostics& diag) {
  const auto ids = target_ids(mission);
  if (std::find(ids.begin(), ids.end(), id) != ids.end()) return true;
  std::string message =
      "unknown target \"" + id + "\" (not in mission " + mission.file.string() + ")";
  const std::string suggestion = closest_match(id, ids);
  if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
  diag.error(mark, where, message);
  return false;
}

void read_true_poses(const YamlField& f, const MissionSpec& mission, Diagnostics& diag,
                     WorldSpec& world) {
  if (!f.expect_map(false)) return;
  loader::check_unique_keys(f);
  for (const auto& kv : f.node()) {
    if (!kv.first.IsScalar()) {
      f.error("expected target ids as keys");
      continue;
    }
    const std::string id = kv.first.Scalar();
    const YamlField entry = f[id];
    const YAML::Mark key_mark = kv.first.Mark();
    const SourceMark mark{f.file(), key_mark.line + 1, key_mark.column + 1};
    if (!check_target_id(id, mission, mark, entry.path(), diag)) continue;
    if (!entry.expect_map()) continue;
    loader::check_keys(entry, {"pose"});
    if (auto T = loader::read_pose(entry["pose"])) world.T_map_model_true[id] = *T;
  }
}

void read_noise(const YamlField& f, WorldSpec& world) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, {"odometry_trans_frac", "odometry_rot_frac", "laser_range_m", "encoder_deg",
                         "encoder_bias_deg", "depth", "depth_artefacts"});
  if (auto bias = loader::read_numbers<2>(f["encoder_bias_deg"], false, "[pan, tilt]")) {
    world.encoder_bias_pan_deg = (*bias)[0];
    world.encoder_bias_tilt_deg = (*bias)[1];
  }
  if (auto v = f["depth_artefacts"].as_bool(false)) world.depth_artefacts = *v;
  auto non_negative = [&](const char* key, double& out) {
    if (auto v = read_number(f[key], false, Sign::non_negative)) out = *v;
  };
  non_negative("odometry_trans_frac", world.odometry_trans_noise_frac);
  non_negative("odometry_rot_frac", world.odometry_rot_noise_frac);
  non_negative("laser_range_m", world.laser_range_noise_m);
  non_negative("encoder_deg", world.encoder_noise_deg);
  if (auto depth = f["depth"].as_enum({"kinect_v1", "none"}, false)) {
    world.depth_noise = *depth == "kinect_v1";
  }
}

void read_faults(const YamlField& f, const MissionSpec& mission, Diagnostics& diag,
                 WorldSpec& world) {
  if (!f.expect_sequence(false)) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const YamlField entry = f[i];
    if (!entry.expect_map()) continue;
    loader::check_unique_keys(entry);
    FaultSpec fault;
    fault.mark = entry.mark();
    bool ok = true;
    const YamlField target = entry["target"];
    if (auto id = target.as_string()) {
      ok &= check_target_id(*id, mission, target.mark(), target.path(), diag);
      fault.target = *id;
    } else {
      ok = false;
    }
    if (auto type = entry["type"].as_enum(fault_type_names())) {
      fault.type = *type;
    } else {
      ok = false;
    }
    const std::size_t errors_before = diag.error_count();
    // Every fault type's numbers, by name and sign, as the simulator reads them: any other key
    // is an error (a misspelt one would silently leave the fault at its default).
    const FaultKindSpec* checked = find_fault_kind(fault.type);
    if (checked != nullptr) {
      std::vector<std::string> allowed = {"target", "type"};
      for (const FaultNumberSpec& n : checked->numbers) allowed.push_back(n.key);
      entry.check_keys(allowed);
    }
    for (const auto& kv : entry.node()) {
      if (!kv.first.IsScalar()) {
        entry.error("expected field names as keys");
        ok = false;
        continue;
      }
      const std::string key = kv.first.Scalar();
      if (key == "target" || key == "type") continue;
      if (auto v = entry[key].as_double()) {
        fault.values[key] = *v;
      } else {
        ok = false;
      }
    }
    if (checked != nullptr) {
      for (const FaultNumberSpec& n : checked->numbers) {
        // Only numbers are checked for their sign: a non-number has had its diagnostic.
        if (fault.values.count(n.key)) read_number(entry[n.key], false, loader_sign(n.sign));
      }
    }
    ok &= diag.error_count() == errors_before;
    if (ok) world.faults.push_back(std::move(fault));
  }
}

// A point [x, y] in the map frame.
std::optional<Eigen::Vector2d> read_point(const YamlField& f, bool required) {
  const auto xy = loader::read_numbers<2>(f, required, "[x, y]");
  if (!xy) return std::nullopt;
  return Eigen::Vector2d((*xy)[0], (*xy)[1]);
}

// [lo, hi] with 0 <= lo <= hi (lo > 0 where `positive`).
std::optional<std::array<double, 2>> read_range(const YamlField& f, bool positive) {
  auto r = loader::read_numbers<2>(f, false, "[min, max]");
  if (!r) return std::nullopt;
  if ((*r)[0] < 0.0 || (positive && (*r)[0] <= 0.0) || (*r)[1] < (*r)[0]) {
    f.error(std::string("expected [min, max] with ") + (positive ? "0 < min" : "0 <= min") +
            " <= max, got [" + loader::format_number((*r)[0]) + ", " +
            loader::format_number((*r)[1]) + "]");
    return std::nullopt;
  }
  return r;
}

void read_objects(const YamlField& f, WorldSpec& world) {
  if (!f.expect_sequence(false)) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const YamlField e = f[i];
    if (!e.expect_map()) continue;
    const auto type = e["type"].as_enum({"box", "cylinder"});
    if (!type) continue;
    WorldObjectSpec o;
    o.mark = e.mark();
    o.shape = *type == "box" ? WorldObjectSpec::Shape::box : WorldObjectSpec::Shape::cylinder;
    bool ok = true;
    if (o.shape == WorldObjectSpec::Shape::box) {
      loader::check_keys(e, {"type", "x", "y", "yaw_deg", "size_m", "height_m"});
      const auto size = loader::read_numbers<2>(e["size_m"], true, "[x, y]");
      if (size && ((*size)[0] <= 0.0 || (*size)[1] <= 0.0)) {
        e["size_m"].error("expected two sizes > 0 m");
        ok = false;
      } else if (size) {
        o.size_x_m = (*size)[0];
        o.size_y_m = (*size)[1];
      }
      ok &= size.has_value();
      if (auto yaw = loader::read_angle_deg(e["yaw_deg"], false)) o.pose.yaw_rad = deg_to_rad(*yaw);
    } else {
      loader::check_keys(e, {"type", "x", "y", "diameter_m", "height_m"});
      const auto d = read_number(e["diameter_m"], true, Sign::positive);
      if (d) o.size_x_m = o.size_y_m = *d;
      ok &= d.has_value();
    }
    const auto x = read_number(e["x"], true), y = read_number(e["y"], true);
    const auto h = read_number(e["height_m"], true, Sign::positive);
    if (!x || !y || !h || !ok) continue;
    o.pose.x_m = *x;
    o.pose.y_m = *y;
    o.height_m = *h;
    world.objects.push_back(o);
  }
}

void read_walls(const YamlField& f, std::vector<WallSegmentSpec>& out) {
  if (!f.expect_sequence(false)) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const YamlField e = f[i];
    if (!e.expect_map()) continue;
    loader::check_keys(e, {"from", "to", "thickness_m"});
    WallSegmentSpec w;
    w.mark = e.mark();
    const auto a = read_point(e["from"], true), b = read_point(e["to"], true);
    const auto t = read_number(e["thickness_m"], false, Sign::positive);
    if (!a || !b) continue;
    if ((*a - *b).norm() < 1e-6) {
      e["to"].error("expected a wall of some length: `to` is `from`");
      continue;
    }
    w.a_m = *a;
    w.b_m = *b;
    if (t) w.thickness_m = *t;
    out.push_back(w);
  }
}

void read_map_error(const YamlField& f, WorldSpec& world) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, {"wall_thinning_m", "shift_m", "rotation_deg", "rotation_about_m",
                         "missing_walls", "extra_walls"});
  MapErrorSpec& m = world.map_error;
  if (auto v = read_point(f["rotation_about_m"], false)) m.rotation_about_m = *v;
  if (auto v = read_number(f["wall_thinning_m"], false, Sign::non_negative)) m.wall_thinning_m = *v;
  if (auto v = read_point(f["shift_m"], false)) {
    m.shift_x_m = v->x();
    m.shift_y_m = v->y();
  }
  if (auto v = loader::read_angle_deg(f["rotation_deg"], false)) m.rotation_deg = *v;
  read_walls(f["missing_walls"], m.missing_walls);
  read_walls(f["extra_walls"], m.extra_walls);
}

void read_clutter(const YamlField& f, WorldSpec& world) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, {"per_m", "size_m", "height_m", "keep_clear_m"});
  ClutterSpec& c = world.clutter;
  if (auto v = read_number(f["per_m"], false, Sign::non_negative)) c.per_m = *v;
  if (auto r = read_range(f["size_m"], true)) {
    c.min_size_m = (*r)[0];
    c.max_size_m = (*r)[1];
  }
  if (auto r = read_range(f["height_m"], true)) {
    c.min_height_m = (*r)[0];
    c.max_height_m = (*r)[1];
  }
  if (auto v = read_number(f["keep_clear_m"], false, Sign::non_negative)) c.keep_clear_m = *v;
}

void read_people(const YamlField& f, WorldSpec& world) {
  if (!f.expect_map(false)) return;
  loader::check_keys(f, {"walkers", "speed_mps", "max_pause_s", "radius_m", "height_m", "list"});
  CrowdSpec& c = world.people;
  if (auto v = loader::read_integer(f["walkers"], false, Sign::non_negative)) {
    c.walkers = static_cast<int>(*v);
  }
  if (auto r = read_range(f["speed_mps"], true)) {
    c.min_speed_mps = (*r)[0];
    c.max_speed_mps = (*r)[1];
  }
  if (auto v = read_number(f["max_pause_s"], false, Sign::non_negative)) c.max_pause_s = *v;
  if (auto v = read_number(f["radius_m"], false, Sign::positive)) c.radius_m = *v;
  if (auto v = read_number(f["height_m"], false, Sign::positive)) c.height_m = *v;
  const YamlField list = f["list"];
  if (!list.expect_sequence(false)) return;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YamlField e = list[i];
    if (!e.expect_map()) continue;
    loader::check_keys(e, {"route", "loop", "start", "speed_mps", "pause_s", "start_s"});
    PersonSpec p;
    p.mark = e.mark();
    bool ok = true;
    const YamlField route = e["route"];
    if (route.expect_sequence(false)) {
      for (std::size_t k = 0; k < route.size(); ++k) {
        if (auto pt = read_point(route[k], true)) {
          p.route_m.push_back(*pt);
        } else {
          ok = false;
        }
      }
      if (ok && route.size() < 2) {
        route.error("expected a route of at least 2 waypoints [[x, y], ...], got " +
                    std::to_string(route.size()));
        ok = false;
      }
    }
    if (auto v = e["loop"].as_bool(false)) p.loop = *v;
    if (e["start"].defined()) {
      if (!p.route_m.empty()) {
        e["start"].error(
            "a person walks either a route (starting at its first waypoint) or at "
            "random from `start`, not both");
        ok = false;
      } else if (auto pt = read_point(e["start"], true)) {
        p.start_m = *pt;
      } else {
        ok = false;
      }
    }
    if (auto v = read_number(e["speed_mps"], false, Sign::positive)) p.speed_mps = *v;
    if (auto v = read_number(e["pause_s"], false, Sign::non_negative)) p.pause_s = *v;
    if (auto v = read_number(e["start_s"], false, Sign::non_negative)) p.start_s = *v;
    if (ok) c.list.push_back(std::move(p));
  }
}

std::optional<WorldSpec> read_world(const YAML::Node& node, const std::string& file,
                                    const MissionSpec& mission, Diagnostics& diag) {
  const std::size_t errors_before = diag.error_count();
  const YamlField root(node, file, diag);
  WorldSpec world;
  world.file = file;
  // An empty world file is the default world.
  if (!root.defined()) return world;
  if (!root.expect_map()) return std::nullopt;
  loader::check_keys(
      root, {"seed", "targets", "target_offset", "noise", "model_error", "calibration_error",
             "faults", "objects", "clutter", "supports", "map_error", "glass", "people"});

  if (auto seed = loader::read_integer(root["seed"], false, Sign::non_negative)) {
    world.seed = static_cast<unsigned long long>(*seed);
  }
  read_true_poses(root["targets"], mission, diag, world);
  const YamlField offset = root["target_offset"];
  if (offset.expect_map(false)) {
    loader::check_keys(offset, {"max_m", "max_deg"});
    if (auto v = read_number(offset["max_m"], false, Sign::non_negative)) {
      world.target_offset_max_m = *v;
    }
    if (auto v = read_number(offset["max_deg"], false, Sign::non_negative)) {
      world.target_offset_max_deg = *v;
    }
  }
  read_noise(root["noise"], world);
  const YamlField model_error = root["model_error"];
  if (model_error.expect_map(false)) {
    loader::check_keys(model_error, {"enabled", "noise_mm"});
    if (auto v = model_error["enabled"].as_bool(false)) world.model_error = *v;
    if (auto v = read_number(model_error["noise_mm"], false, Sign::non_negative)) {
      world.model_error_noise_mm = *v;
    }
  }
  const YamlField calibration = root["calibration_error"];
  if (calibration.expect_map(false)) {
    loader::check_keys(calibration, {"trans_mm", "rot_deg"});
    if (auto v = read_number(calibration["trans_mm"], false, Sign::non_negative)) {
      world.calibration_error_mm = *v;
    }
    if (auto v = read_number(calibration["rot_deg"], false, Sign::non_negative)) {
      world.calibration_error_deg = *v;
    }
  }
  read_faults(root["faults"], mission, diag, world);
  read_objects(root["objects"], world);
  read_clutter(root["clutter"], world);
  if (auto v = root["supports"].as_bool(false)) world.supports = *v;
  read_map_error(root["map_error"], world);
  read_walls(root["glass"], world.glass);
  read_people(root["people"], world);

  if (diag.error_count() > errors_before) return std::nullopt;
  return world;
}

}  // namespace

std::optional<WorldSpec> load_world(const std::filesystem::path& file, const MissionSpec& mission,
                                    Diagnostics& diag) {
  const auto node = load_yaml_file(file, diag);
  if (!node) return std::nullopt;
  return read_world(*node, file.string(), mission, diag);
}

}  // namespace projtour::host
