#include "projtour/commands/localize_command.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "projtour/cli/options.hpp"
#include "projtour/navigation/localizer.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/navigation/path_planner.hpp"

namespace projtour {

namespace {

constexpr const char* kUsage =
    "usage: projtour localize --map M --rawlog R (--init X,Y,YAW_DEG | --score T.tum) "
    "[--particles N] [--seed S] [--field boundary|occupied] [--truth GT] [--from-scan K] "
    "[--out T.tum]\n";

struct Arguments {
  std::string map, rawlog, out, truth, score;
  Pose2D init;
  bool have_init = false;
  int particles = navigation::LocalizerOptions{}.particles;
  std::uint64_t seed = 1;
  navigation::LocalizerOptions::Field field = navigation::LocalizerOptions{}.lf_field;
  int from_scan = 0;
};

// Endpoints this near a wall face of the map count as on it.
constexpr double kOnMapM = 0.1;
// A trajectory's pose is matched to a scan within this of its timestamp.
constexpr double kMatchS = 0.05;

struct StampedPose {
  double t_s;
  Pose2D pose;
};

// MRPT's ground truth ("t x y phi", phi in radians, more columns ignored) or TUM ("t x y z qx
// qy qz qw"), told apart by the column count. Throws naming the file and line.
std::vector<StampedPose> read_trajectory(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file + ": cannot read");
  std::vector<StampedPose> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> v;
    double x = 0.0;
    while (fields >> x) v.push_back(x);
    if (v.size() == 8) {
      out.push_back({v[0], Pose2D{v[1], v[2], 2.0 * std::atan2(v[6], v[7])}});
    } else if (v.size() >= 4 && v.size() != 8) {
      out.push_back({v[0], Pose2D{v[1], v[2], v[3]}});
    } else {
      throw std::runtime_error(file + ":" + std::to_string(number) +
                               ": expected \"t x y phi\" or TUM \"t x y z qx qy qz qw\"");
    }
  }
  if (out.empty()) throw std::runtime_error(file + ": no poses");
  std::sort(out.begin(), out.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.t_s < b.t_s; });
  return out;
}

const StampedPose* nearest(const std::vector<StampedPose>& trajectory, double t_s) {
  auto it = std::lower_bound(trajectory.begin(), trajectory.end(), t_s,
                             [](const StampedPose& p, double t) { return p.t_s < t; });
  const StampedPose* best = nullptr;
  if (it != trajectory.end()) best = &*it;
  if (it != trajectory.begin() && (!best || t_s - std::prev(it)->t_s < best->t_s - t_s)) {
    best = &*std::prev(it);
  }
  return best && std::abs(best->t_s - t_s) <= kMatchS ? best : nullptr;
}

// Distance from each cell's centre to the nearest wall face. The face runs between cells, half a
// cell from the centres on either side of it.
cv::Mat wall_face_distance_m(const mrpt::maps::COccupancyGridMap2D& map) {
  cv::Mat distance_m = (navigation::wall_face_distance_cells(map) - 0.5) * map.getResolution();
  return cv::max(distance_m, 0.0);
}

// The scan's valid endpoints seen from `pose`, and how many lie within kOnMapM of a wall face.
std::pair<std::size_t, std::size_t> endpoints_on_map(
    const mrpt::maps::COccupancyGridMap2D& map, const cv::Mat& distance_m, const Pose2D& pose,
    const mrpt::obs::CObservation2DRangeScan& scan) {
  const std::vector<Eigen::Vector2d> ends = navigation::scan_endpoints_m(pose, scan);
  std::size_t on = 0;
  for (const Eigen::Vector2d& end : ends) {
    const int cx = map.x2idx(end.x()), cy = map.y2idx(end.y());
    if (cx >= 0 && cy >= 0 && cx < distance_m.cols && cy < distance_m.rows &&
        distance_m.at<float>(cy, cx) <= kOnMapM + 1e-4) {  // a cell beside the face on 0.2 m cells
      ++on;
    }
  }
  return {on, ends.size()};
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

bool parse_init(const std::string& text, Pose2D& out) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    double v = 0.0;
    if (!cli::parse_whole(item, v) || !std::isfinite(v)) return false;
    values.push_back(v);
  }
  if (values.size() != 3 || text.back() == ',') return false;
  out = Pose2D{values[0], values[1], deg_to_rad(values[2])};
  return true;
}

std::optional<Arguments> parse(int argc, char** argv) {
  Arguments args;
  CLI::App app("projtour localize", "projtour localize");
  app.set_help_flag();
  app.allow_extras();
  app.add_option_function<std::string>("--map", [&](const std::string& v) { args.map = v; });
  app.add_option_function<std::string>("--rawlog", [&](const std::string& v) { args.rawlog = v; });
  app.add_option_function<std::string>("--out", [&](const std::string& v) { args.out = v; });
  app.add_option_function<std::string>("--truth", [&](const std::string& v) { args.truth = v; });
  app.add_option_function<std::string>("--score", [&](const std::string& v) { args.score = v; });
  app.add_option_function<std::string>("--field", [&](const std::string& v) {
    if (v == "boundary") {
      args.field = navigation::LocalizerOptions::Field::boundary;
    } else if (v == "occupied") {
      args.field = navigation::LocalizerOptions::Field::occupied;
    } else {
      throw CLI::ValidationError("--field", "expects boundary or occupied, got \"" + v + "\"");
    }
  });
  cli::add_int(
      app, "--from-scan",
      [&](int n) {
        if (n < 0) throw CLI::ValidationError("--from-scan", "must be >= 0");
        args.from_scan = n;
      },
      "K");
  app.add_option_function<std::string>("--init", [&](const std::string& v) {
    if (!parse_init(v, args.init)) {
      throw CLI::ValidationError("--init", "expects X,Y,YAW_DEG, got \"" + v + "\"");
    }
    args.have_init = true;
  });
  cli::add_int(
      app, "--particles",
      [&](int n) {
        if (n < 1) throw CLI::ValidationError("--particles", "must be >= 1");
        args.particles = n;
      },
      "N");
  cli::add_uint64(
      app, "--seed", [&](std::uint64_t s) { args.seed = s; }, "S");
  for (CLI::Option* option : app.get_options()) {
    option->multi_option_policy(CLI::MultiOptionPolicy::Throw);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    std::cerr << "projtour localize: " << e.what() << "\n" << kUsage;
    return std::nullopt;
  }
  if (!app.remaining().empty()) {
    std::cerr << "projtour localize: unknown option " << app.remaining().front() << "\n" << kUsage;
    return std::nullopt;
  }
  if (args.map.empty() || args.rawlog.empty() || args.have_init == !args.score.empty()) {
    std::cerr << "projtour localize: --map, --rawlog and one of --init and --score are required\n"
              << kUsage;
    return std::nullopt;
  }
  return args;
}

// A bar redrawn in place on a terminal; a line per tenth otherwise, so logs stay readable.
class Progress {
 public:
  explicit Progress(std::size_t total) : total_(total), tty_(::isatty(STDERR_FILENO) != 0) {}
  void update(std::size_t done, std::size_t scans) {
    const int percent = total_ == 0 ? 100 : static_cast<int>(100 * done / total_);
    if (tty_) {
      if (percent == last_percent_) return;
      const int filled = percent * 30 / 100;
      std::cerr << "\rlocalize [" << std::string(filled, '#') << std::string(30 - filled, ' ')
                << "] " << std::setw(3) << percent << "% " << scans << " scans" << std::flush;
    } else if (percent / 10 != last_percent_ / 10) {
      std::cerr << "localize: " << percent << "% (" << scans << " scans)\n";
    }
    last_percent_ = percent;
  }
  void finish() {
    if (tty_) std::cerr << "\n";
  }

 private:
  std::size_t total_;
  bool tty_;
  int last_percent_ = -1;
};

void write_tum(std::ostream& out, double t_s, const Pose2D& p) {
  out << std::fixed << std::setprecision(6) << t_s << " " << p.x_m << " " << p.y_m << " 0 0 0 "
      << std::sin(0.5 * p.yaw_rad) << " " << std::cos(0.5 * p.yaw_rad) << "\n";
}

// What the command reads: the map, the rawlog and the trajectories to score against or to
// score. False (with the reason on stderr) when one cannot be read.
struct Inputs {
  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  mrpt::obs::CRawlog rawlog;
  std::vector<StampedPose> truth, scored;
};

bool load_inputs(const Arguments& args, Inputs& in) {
  try {
    in.map = navigation::load_occupancy_grid(args.map);
  } catch (const std::exception& e) {
    std::cerr << "projtour localize: " << e.what() << "\n";
    return false;
  }
  if (!std::filesystem::exists(args.rawlog) || !in.rawlog.loadFromRawLogFile(args.rawlog)) {
    std::cerr << "projtour localize: " << args.rawlog << ": cannot read the rawlog\n";
    return false;
  }
  try {
    if (!args.truth.empty()) in.truth = read_trajectory(args.truth);
    if (!args.score.empty()) in.scored = read_trajectory(args.score);
  } catch (const std::exception& e) {
    std::cerr << "projtour localize: " << e.what() << "\n";
    return false;
  }
  return true;
}

// What the replay counts over the scans, for the summary.
struct Tally {
  std::size_t scans = 0, converged_scans = 0, unscored = 0;
  std::size_t endpoints_on = 0, endpoints = 0;
  std::vector<double> errors_m;
  double update_s = 0.0;
};

// The rawlog replayed in order: each scan localized (or, with --score, looked up in the
// trajectory scored), its pose written out and checked against the map and the truth.
class Replay {
 public:
  Replay(const Arguments& args, const Inputs& in, navigation::Localizer& localizer,
         std::ostream& out)
      : args_(args),
        in_(in),
        localizer_(localizer),
        out_(out),
        distance_m_(wall_face_distance_m(*in.map)) {}

  // Throws what the rawlog's entries or the localizer throw.
  void run(Progress& progress) {
    const mrpt::obs::CRawlog& rawlog = in_.rawlog;
    for (std::size_t i = 0; i < rawlog.size(); ++i) {
      switch (rawlog.getType(i)) {
        case mrpt::obs::CRawlog::etActionCollection: {
          const auto actions = rawlog.getAsAction(i);
          if (const auto movement = actions->getBestMovementEstimation()) {
            const mrpt::poses::CPose2D d =
                movement->estimationMethod == mrpt::obs::CActionRobotMovement2D::emOdometry
                    ? movement->rawOdometryIncrementReading
                    : movement->poseChange->getMeanVal();
            add_odometry(Pose2D{d.x(), d.y(), d.phi()});
          }
          break;
        }
        case mrpt::obs::CRawlog::etSensoryFrame: {
          const auto frame = rawlog.getAsObservations(i);
          if (const auto scan =
                  frame->getObservationByClass<mrpt::obs::CObservation2DRangeScan>()) {
            process_scan(*scan);
          }
          break;
        }
        case mrpt::obs::CRawlog::etObservation:
          observation(rawlog.getAsObservation(i));
          break;
        default:
          break;
      }
      progress.update(i + 1, tally_.scans);
    }
  }

  const Tally& tally() const { return tally_; }

 private:
  void observation(const mrpt::obs::CObservation::Ptr& obs) {
    if (const auto odo = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(obs)) {
      const Pose2D now{odo->odometry.x(), odo->odometry.y(), odo->odometry.phi()};
      if (last_odometry_) add_odometry(navigation::pose_delta(*last_odometry_, now));
      last_odometry_ = now;
    } else if (const auto scan =
                   std::dynamic_pointer_cast<mrpt::obs::CObservation2DRangeScan>(obs)) {
      process_scan(*scan);
    }
  }

  void add_odometry(const Pose2D& increment) {
    pending_ = navigation::pose_compose(pending_, increment);
  }

  void process_scan(const mrpt::obs::CObservation2DRangeScan& scan) {
    const double t_s = scan.timestamp == mrpt::Clock::time_point()
                           ? static_cast<double>(tally_.scans)
                           : mrpt::Clock::toDouble(scan.timestamp);
    std::optional<Pose2D> pose;
    if (in_.scored.empty()) {
      const auto t0 = std::chrono::steady_clock::now();
      localizer_.update(pending_, scan);
      tally_.update_s +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      pose = localizer_.estimate().mean;
      if (localizer_.converged()) ++tally_.converged_scans;
    } else if (const StampedPose* p = nearest(in_.scored, t_s)) {
      pose = p->pose;
    }
    pending_ = Pose2D{};
    const bool counted = static_cast<int>(tally_.scans++) >= args_.from_scan;
    if (!pose) {
      ++tally_.unscored;
      return;
    }
    write_tum(out_, t_s, *pose);
    if (!counted) return;
    const auto [on, valid] = endpoints_on_map(*in_.map, distance_m_, *pose, scan);
    tally_.endpoints_on += on;
    tally_.endpoints += valid;
    if (!in_.truth.empty()) {
      if (const StampedPose* t = nearest(in_.truth, t_s)) {
        tally_.errors_m.push_back(std::hypot(pose->x_m - t->pose.x_m, pose->y_m - t->pose.y_m));
      }
    }
  }

  const Arguments& args_;
  const Inputs& in_;
  navigation::Localizer& localizer_;
  std::ostream& out_;
  const cv::Mat distance_m_;
  // Odometry arrives either as action collections (increments) or, in observation-only
  // rawlogs, as absolute odometry readings; both become the increment since the last scan.
  Pose2D pending_;
  std::optional<Pose2D> last_odometry_;
  Tally tally_;
};

// The summary on stderr; the exit code: 2 when no truth pose matched any scan, else 0.
int print_summary(const Arguments& args, const Inputs& in, const navigation::Localizer& localizer,
                  const Tally& tally) {
  const std::size_t scans = tally.scans;
  if (in.scored.empty()) {
    const PoseEstimate2D final_estimate = localizer.estimate();
    std::fprintf(stderr,
                 "localize: %zu scans, converged for %zu (%.0f%%), final std %.3f m %.2f deg, "
                 "scans on the map's walls %.0f%%, %.2f ms per update with %zu particles\n",
                 scans, tally.converged_scans, 100.0 * tally.converged_scans / scans,
                 navigation::position_std_m(final_estimate),
                 rad_to_deg(navigation::yaw_std_rad(final_estimate)), 100.0 * localizer.scan_fit(),
                 1000.0 * tally.update_s / scans, localizer.particle_count());
  } else {
    std::fprintf(stderr, "localize: %zu scans, %zu with no pose in %s\n", scans, tally.unscored,
                 args.score.c_str());
  }
  std::fprintf(
      stderr, "localize: endpoints within %.2f m of a wall face from scan %d: %.1f%% of %zu\n",
      kOnMapM, args.from_scan, tally.endpoints ? 100.0 * tally.endpoints_on / tally.endpoints : 0.0,
      tally.endpoints);
  if (!in.truth.empty()) {
    const std::vector<double>& errors_m = tally.errors_m;
    if (errors_m.empty()) {
      std::cerr << "projtour localize: " << args.truth << ": no pose within " << kMatchS
                << " s of any scan\n";
      return 2;
    }
    double sum_sq = 0.0;
    for (double e : errors_m) sum_sq += e * e;
    std::fprintf(stderr, "localize: ATE over %zu scans: rms %.4f m, median %.4f m, max %.4f m\n",
                 errors_m.size(), std::sqrt(sum_sq / errors_m.size()), median(errors_m),
                 *std::max_element(errors_m.begin(), errors_m.end()));
  }
  return 0;
}

}  // namespace

int run_localize_command(int argc, char** argv) {
  const auto args = parse(argc, argv);
  if (!args) return 2;
  Inputs in;
  if (!load_inputs(*args, in)) return 2;

  std::ofstream file;
  if (!args->out.empty()) {
    file.open(args->out);
    if (!file) {
      std::cerr << "projtour localize: " << args->out << ": cannot write\n";
      return 2;
    }
  }
  std::ostream& out = args->out.empty() ? std::cout : file;

  navigation::LocalizerOptions options;
  options.particles = args->particles;
  options.lf_field = args->field;
  navigation::Localizer localizer(*in.map, options, args->seed);
  localizer.reset(args->init);
  Replay replay(*args, in, localizer, out);
  Progress progress(in.rawlog.size());
  try {
    replay.run(progress);
  } catch (const std::exception& e) {
    progress.finish();
    std::cerr << "projtour localize: " << e.what() << "\n";
    return 1;
  }
  progress.finish();
  if (!out) {
    std::cerr << "projtour localize: " << args->out << ": write failed\n";
    return 1;
  }
  if (replay.tally().scans == 0) {
    std::cerr << "projtour localize: " << args->rawlog << ": no 2-D laser scans\n";
    return 2;
  }
  return print_summary(*args, in, localizer, replay.tally());
}

}  // namespace projtour
