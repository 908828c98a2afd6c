// The mission file (format in README.md, "Mission files").
#include "projtour/host/mission_loader.hpp"

#include <array>

#include <opencv2/imgcodecs.hpp>

#include "loader_fields.hpp"

namespace projtour::host {

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
// All day (README "All day"): a day has at most 10,000 rounds of even a one-target tour (8.6 s
// each); a pause of a day between rounds or 24 windows a day is no schedule anyone means; 64
// items of content per target is a playlist, more is a mistake in the list.
constexpr long long kMaxRounds = 10000;
constexpr double kMaxPauseS = 86400.0;
constexpr std::size_t kMaxWindows = 24;
constexpr std::size_t kMaxContentItems = 64;
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

// "HH:MM" or "HH:MM:SS" from 00:00 to 24:00 as seconds after midnight; nullopt when it is not
// one.
std::optional<int> parse_time_of_day(const std::string& text) {
  if (text.size() != 5 && text.size() != 8) return std::nullopt;
  std::array<int, 3> parts{0, 0, 0};
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (i % 3 == 2) {
      if (c != ':') return std::nullopt;
    } else if (c < '0' || c > '9') {
      return std::nullopt;
    } else {
      parts[i / 3] = parts[i / 3] * 10 + (c - '0');
    }
  }
  const auto [h, m, sec] = parts;
  if (m > 59 || sec > 59 || h > 24 || (h == 24 && (m != 0 || sec != 0))) return std::nullopt;
  return h * 3600 + m * 60 + sec;
}

std::optional<int> read_time_of_day(const YamlField& f) {
  const auto text = f.as_string(false);
  if (!text) return std::nullopt;
  const auto t = parse_time_of_day(*text);
  if (!t)
    f.error("expected a time of day \"HH:MM\" or \"HH:MM:SS\" from 00:00 to 24:00, got \"" + *text +
            "\"");
  return t;
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
    loader::check_keys(
        root_, {"mission", "map", "robot", "start", "targets", "order", "machine", "schedule"});

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
    read_schedule(note(root_["schedule"]));

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
                           "dwell_s", "tolerance_mm", "hours", "rotate"});
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
    TargetTimes times;
    read_content_list(note(f["content"]), times);
    if (!times.content.empty()) target.content = times.content.front();
    if (auto rotate = note(f["rotate"]).as_enum({"per_visit", "per_round"}, false)) {
      times.per_round = *rotate == "per_round";
    }
    read_hours(note(f["hours"]), times);
    if (auto v = read_bounded(note(f["standoff_m"]), kMaxStandoffM)) target.standoff_m = *v;
    if (auto v = read_bounded(note(f["dwell_s"]), kMaxDwellS)) target.dwell_s = *v;
    if (auto v = read_bounded(note(f["tolerance_mm"]), kMaxToleranceMm)) target.tolerance_mm = *v;

    if (diag_.error_count() > errors_before) return std::nullopt;
    mission_.target_times.push_back(std::move(times));
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

  // One image or video, or a list of them shown in turn.
  void read_content_list(const YamlField& f, TargetTimes& times) {
    if (!f.is_sequence()) {
      if (auto path = read_content(f)) times.content.push_back(*path);
      return;
    }
    if (f.size() == 0 || f.size() > kMaxContentItems) {
      f.error("expected 1 to " + std::to_string(kMaxContentItems) + " images or videos, got " +
              std::to_string(f.size()));
      return;
    }
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (auto path = read_content(note(f[i]))) times.content.push_back(*path);
    }
  }

  void read_hours(const YamlField& f, TargetTimes& times) {
    if (!f.expect_sequence(false)) return;
    if (f.size() == 0 || f.size() > kMaxWindows) {
      f.error("expected 1 to " + std::to_string(kMaxWindows) + " windows \"HH:MM-HH:MM\", got " +
              std::to_string(f.size()));
      return;
    }
    for (std::size_t i = 0; i < f.size(); ++i) {
      const YamlField w = note(f[i]);
      const auto text = w.as_string();
      if (!text) continue;
      const auto dash = text->find('-');
      const auto begin = parse_time_of_day(text->substr(0, dash));
      const auto end =
          dash == std::string::npos ? std::nullopt : parse_time_of_day(text->substr(dash + 1));
      if (!begin || !end) {
        w.error("expected a window \"HH:MM-HH:MM\" of times from 00:00 to 24:00, got \"" + *text +
                "\"");
      } else if (*begin >= *end) {
        w.error(
            "expected a window that ends after it begins (one day, not across midnight), got \"" +
            *text + "\"");
      } else {
        times.hours.push_back(TimeWindow{*begin, *end});
      }
    }
  }

  void read_schedule(const YamlField& f) {
    if (!f.expect_map(false)) return;
    loader::check_keys(f, {"rounds", "until", "start", "pause_s"});
    MissionSchedule& schedule = mission_.schedule;
    schedule.written = true;
    const YamlField rounds = note(f["rounds"]);
    if (auto n = loader::read_integer(rounds, false, Sign::positive)) {
      if (*n > kMaxRounds) {
        rounds.error("expected an integer > 0 and at most " + std::to_string(kMaxRounds) +
                     ", got " + rounds.node().Scalar());
      } else {
        schedule.rounds = *n;
      }
    }
    const YamlField until = note(f["until"]);
    schedule.until_s = read_time_of_day(until);
    const YamlField start = note(f["start"]);
    if (auto t = read_time_of_day(start)) schedule.start_s = *t;
    if (auto v = read_number(note(f["pause_s"]), false, Sign::non_negative)) {
      if (*v > kMaxPauseS) {
        f["pause_s"].error("expected a number >= 0 and at most " +
                           loader::format_number(kMaxPauseS) + ", got " +
                           f["pause_s"].node().Scalar());
      } else {
        schedule.pause_s = *v;
      }
    }
    if (!rounds.defined() && !until.defined()) {
      f.error("expected rounds (how many passes) or until (a time of day), or both");
    }
    if (schedule.until_s && start.defined() && *schedule.until_s <= schedule.start_s) {
      until.error("expected a time after start (" + start.node().Scalar() +
                  "): a schedule does not cross midnight");
    }
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

}  // namespace projtour::host
