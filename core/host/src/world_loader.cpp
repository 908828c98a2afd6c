// The world file of a dry run (format documented in examples/worlds/atrium_faults.yaml).
#include <map>

#include "loader_fields.hpp"
#include "projtour/mission_loader.hpp"

namespace projtour {

namespace {

using loader::read_number;
using loader::Sign;

const std::vector<std::string> kFaultTypes = {
    "frame_dropout",     "target_missing",    "occluder",     "blocked_path", "kidnap",
    "camera_disconnect", "projector_failure", "target_nudge", "pole",         "daylight"};

// Fault types whose numbers are checked here, by name and sign. The others' numbers need only be
// numbers (what they mean is the simulator's business, and older files carry unused ones).
struct FaultNumber {
  const char* key;
  Sign sign;
};
const std::map<std::string, std::vector<FaultNumber>> kCheckedFaults = {
    {"pole",
     {{"distance_m", Sign::positive}, {"diameter_m", Sign::positive}, {"offset_m", Sign::any}}},
    {"daylight", {{"lux", Sign::positive}}},
};

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
  loader::check_keys(
      f, {"odometry_trans_frac", "odometry_rot_frac", "laser_range_m", "encoder_deg", "depth"});
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
    if (auto type = entry["type"].as_enum(kFaultTypes)) {
      fault.type = *type;
    } else {
      ok = false;
    }
    const std::size_t errors_before = diag.error_count();
    const auto checked = kCheckedFaults.find(fault.type);
    if (checked != kCheckedFaults.end()) {
      std::vector<std::string> allowed = {"target", "type"};
      for (const FaultNumber& n : checked->second) allowed.push_back(n.key);
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
    if (checked != kCheckedFaults.end()) {
      for (const FaultNumber& n : checked->second) {
        // Only numbers are checked for their sign: a non-number has had its diagnostic.
        if (fault.values.count(n.key)) read_number(entry[n.key], false, n.sign);
      }
    }
    ok &= diag.error_count() == errors_before;
    if (ok) world.faults.push_back(std::move(fault));
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
  loader::check_keys(root, {"seed", "targets", "target_offset", "noise", "model_error",
                            "calibration_error", "faults"});

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

}  // namespace projtour
