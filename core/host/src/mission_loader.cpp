// The mission file (format in DESIGN.md "Mission files").
#include "projtour/mission_loader.hpp"

#include <opencv2/imgcodecs.hpp>

#include "loader_fields.hpp"

namespace projtour {

namespace {

using loader::lower_extension;
using loader::read_number;
using loader::Sign;

// Meshes only: the simulator renders the surface and the Model Points are checked against it
// before a run (a point cloud has no surface to be on).
const std::vector<std::string> kModelExtensions = {".ply", ".off"};
// Bounds no tour reaches, so a typo (a dwell in milliseconds, a stand-off in centimetres) is an
// error now rather than a tour that never ends or a robot that never arrives: a day of dwell at
// one target, a stand-off beyond any depth camera's range, a tolerance of a metre.
constexpr double kMaxDwellS = 86400.0;
constexpr double kMaxStandoffM = 20.0;
constexpr double kMaxToleranceMm = 1000.0;
const std::vector<std::string> kImageExtensions = {".png", ".jpg", ".jpeg", ".bmp"};
const std::vector<std::string> kVideoExtensions = {".mp4", ".avi", ".mkv", ".webm"};

bool contains(const std::vector<std::string>& list, const std::string& word) {
  return std::find(list.begin(), list.end(), word) != list.end();
}

std::string join(const std::vector<std::string>& words, const std::string& last_separator) {
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i) {
    if (i > 0) out += (i + 1 == words.size()) ? last_separator : ", ";
    out += words[i];
  }
  return out;
}

// A path whose kind is known by its extension: the extension is checked before existence so a
// wrong kind of file is reported as such, not as a missing file.
std::optional<std::filesystem::path> read_typed_path(const YamlField& f,
                                                     const std::vector<std::string>& extensions,
                                                     const std::string& what) {
  const auto unchecked = f.as_path(true, false);
  if (!unchecked) return std::nullopt;
  if (!contains(extensions, lower_extension(*unchecked))) {
    f.error("expected " + what + " (" + join(extensions, " or ") + "), got \"" + f.node().Scalar() +
            "\"");
    return std::nullopt;
  }
  return f.as_path(true, true);
}

// A number > 0 and at most `most`.
std::optional<double> read_bounded(const YamlField& f, double most) {
  const auto v = read_number(f, false, Sign::positive);
  if (v && *v > most) {
    f.error("expected a number > 0 and at most " + loader::format_number(most) + ", got " +
            f.node().Scalar());
    return std::nullopt;
  }
  return v;
}

// Paths, marks and the checks that need more than one field of a mission.
class MissionReader {
 public:
  MissionReader(const YAML::Node& node, const std::string& file, Diagnostics& diag)
      : root_(node, file, diag), diag_(diag) {
    mission_.file = file;
  }

  std::optional<LoadedMission> read() {
    const std::size_t errors_before = diag_.error_count();
    if (!root_.defined()) {
      root_.error(
          "empty mission file: expected a mapping with mission, map, robot, start and "
          "targets");
      return std::nullopt;
    }
    if (!root_.expect_map()) return std::nullopt;
    loader::check_keys(root_, {"mission", "map", "robot", "start", "targets", "order", "machine"});

    if (auto name = note(root_["mission"]).as_string()) {
      if (name->empty()) {
        root_["mission"].error("expected a mission name, got an empty string");
      }
      mission_.name = *name;
    }
    const YamlField map = note(root_["map"]);
    if (auto path = read_typed_path(map, {".yaml", ".yml"}, "a ROS map_server map file")) {
      mission_.map = *path;
    }
    if (auto path = note(root_["robot"]).as_path()) {
      mission_.robot_file = *path;
      // The robot file reports its own problems under its own name.
      if (auto robot = load_robot(*path, diag_)) {
        mission_.drivers = std::move(robot->drivers);
        mission_.services = std::move(robot->services);
        mission_.robot = static_cast<RobotSpec&&>(std::move(*robot));
      }
    }
    if (auto start = loader::read_pose2d(note(root_["start"]))) mission_.start = *start;
    read_targets(note(root_["targets"]));
    if (auto order = note(root_["order"]).as_enum({"mission", "nearest"}, false)) {
      mission_.order = *order;
    }
    read_machine(note(root_["machine"]));

    if (diag_.error_count() > errors_before) return std::nullopt;
    return std::move(mission_);
  }

 private:
  // By value: callers pass temporaries such as root_["map"].
  YamlField note(const YamlField& f) {
    mission_.marks[f.path()] = f.mark();
    return f;
  }

  void read_targets(const YamlField& targets) {
    if (!targets.expect_sequence()) return;
    if (targets.size() == 0) {
      targets.error("expected at least one target");
      return;
    }
    std::map<std::string, int> first_line_of_id;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      if (auto target = read_target(note(targets[i]), first_line_of_id)) {
        mission_.targets.push_back(std::move(*target));
      }
    }
  }

  std::optional<TargetSpec> read_target(const YamlField& f,
                                        std::map<std::string, int>& first_line_of_id) {
    if (!f.expect_map()) return std::nullopt;
    loader::check_keys(f, {"id", "model", "pose", "model_points", "content", "standoff_m",
                           "dwell_s", "tolerance_mm"});
    const std::size_t errors_before = diag_.error_count();
    TargetSpec target;

    const YamlField id = note(f["id"]);
    if (auto text = id.as_string()) {
      if (!loader::is_portable_id(*text)) {
        id.error("expected an id of letters, digits, '_' and '-' (it names a directory), got \"" +
                 *text + "\"");
      } else if (auto [it, inserted] = first_line_of_id.emplace(*text, id.mark().line); !inserted) {
        id.error("duplicate target id \"" + *text + "\" (first used at line " +
                 std::to_string(it->second) + ")");
      }
      target.id = *text;
    }
    const auto model_kind = "a model file";
    if (auto path = read_typed_path(note(f["model"]), kModelExtensions, model_kind)) {
      target.model = *path;
    }
    if (auto T = loader::read_pose(note(f["pose"]))) target.T_map_model = *T;
    read_model_points(note(f["model_points"]), target);
    if (auto path = read_content(note(f["content"]))) target.content = *path;
    if (auto v = read_bounded(note(f["standoff_m"]), kMaxStandoffM)) target.standoff_m = *v;
    if (auto v = read_bounded(note(f["dwell_s"]), kMaxDwellS)) target.dwell_s = *v;
    if (auto v = read_bounded(note(f["tolerance_mm"]), kMaxToleranceMm)) target.tolerance_mm = *v;

    if (diag_.error_count() > errors_before) return std::nullopt;
    return target;
  }

  void read_model_points(const YamlField& f, TargetSpec& target) {
    if (!f.expect_sequence()) return;
    bool ok = true;
    if (f.size() != 4) {
      f.error("expected 4 points (top-left, top-right, bottom-right, bottom-left), got " +
              std::to_string(f.size()));
      ok = false;
    }
    for (std::size_t i = 0; i < f.size(); ++i) {
      const auto p = loader::read_numbers<3>(note(f[i]), true, "[x, y, z]");
      if (!p) {
        ok = false;
      } else if (i < 4) {
        target.model_points[i] = Eigen::Vector3d((*p)[0], (*p)[1], (*p)[2]);
      }
    }
    if (!ok) return;
    // The homography from the content's corners needs a quadrilateral: no three corners on one
    // line (which includes two coinciding). 1 mm^2 of triangle area is far below any target.
    const auto& q = target.model_points;
    for (std::size_t a = 0; a < 4; ++a) {
      for (std::size_t b = a + 1; b < 4; ++b) {
        for (std::size_t c = b + 1; c < 4; ++c) {
          if (0.5 * (q[b] - q[a]).cross(q[c] - q[a]).norm() < 1e-6) {
            f.error("points " + std::to_string(a) + ", " + std::to_string(b) + " and " +
                    std::to_string(c) + " lie on one line; the four corners must enclose an area");
            return;
          }
        }
      }
    }
  }

  std::optional<std::filesystem::path> read_content(const YamlField& f) {
    std::vector<std::string> extensions = kImageExtensions;
    extensions.insert(extensions.end(), kVideoExtensions.begin(), kVideoExtensions.end());
    auto path = read_typed_path(f, extensions, "an image or a video");
    if (path && contains(kImageExtensions, lower_extension(*path)) &&
        !cv::haveImageReader(path->string())) {
      f.error("file \"" + f.node().Scalar() + "\" is not an image OpenCV can read (" +
              path->string() + ")");
      return std::nullopt;
    }
    return path;
  }

  void read_machine(const YamlField& f) {
    MachineSource& machine = mission_.machine;
    if (!f.defined()) return;
    if (f.is_map()) {
      machine.is_default = false;
      machine.node = f.node();
      machine.file = f.file();
      machine.path = f.path();
      return;
    }
    if (!f.is_scalar()) {
      f.error("expected \"default\", a file path or a state machine mapping, got a list");
      return;
    }
    if (f.node().Scalar() == "default") return;
    const auto path = read_typed_path(f, {".yaml", ".yml"}, "a state machine file");
    if (!path) return;
    const auto node = load_yaml_file(*path, diag_);
    if (!node) return;
    const YamlField machine_root(*node, path->string(), diag_);
    if (!machine_root.is_map()) {
      machine_root.error("expected a state machine mapping");
      return;
    }
    machine.is_default = false;
    machine.node = *node;
    machine.file = path->string();
    machine.path = "";
  }

  YamlField root_;
  Diagnostics& diag_;
  LoadedMission mission_;
};

}  // namespace

SourceMark LoadedMission::mark_of(const std::string& field_path) const {
  const auto it = marks.find(field_path);
  if (it != marks.end()) return it->second;
  return SourceMark{file.string(), 0, 0};
}

std::optional<LoadedMission> load_mission(const std::filesystem::path& file, Diagnostics& diag) {
  const auto node = load_yaml_file(file, diag);
  if (!node) return std::nullopt;
  return MissionReader(*node, file.string(), diag).read();
}

std::optional<LoadedMission> load_mission_from_string(const std::string& text,
                                                      const std::filesystem::path& file_name,
                                                      Diagnostics& diag) {
  const auto node = load_yaml_string(text, file_name.string(), diag);
  if (!node) return std::nullopt;
  return MissionReader(*node, file_name.string(), diag).read();
}

LoadedMission load_mission_or_throw(const std::filesystem::path& file) {
  Diagnostics diag;
  auto mission = load_mission(file, diag);
  if (!mission) throw InputError(std::move(diag));
  return std::move(*mission);
}

}  // namespace projtour
