#include "projtour_executor/localize_command.hpp"

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <unistd.h>

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

#include "cli_options.hpp"
#include "projtour/localizer.hpp"
#include "projtour/occupancy_map.hpp"

namespace projtour {

namespace {

constexpr const char* kUsage =
    "usage: projtour localize --map M --rawlog R --init X,Y,YAW_DEG [--particles N] [--seed S] "
    "[--out T.tum]\n";

struct Arguments {
  std::string map, rawlog, out;
  Pose2D init;
  int particles = LocalizerOptions{}.particles;
  std::uint64_t seed = 1;
};

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
  bool have_init = false;
  app.add_option_function<std::string>("--init", [&](const std::string& v) {
    if (!parse_init(v, args.init)) {
      throw CLI::ValidationError("--init", "expects X,Y,YAW_DEG, got \"" + v + "\"");
    }
    have_init = true;
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
  if (args.map.empty() || args.rawlog.empty() || !have_init) {
    std::cerr << "projtour localize: --map, --rawlog and --init are required\n" << kUsage;
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

}  // namespace

int run_localize_command(int argc, char** argv) {
  const auto args = parse(argc, argv);
  if (!args) return 2;

  std::shared_ptr<mrpt::maps::COccupancyGridMap2D> map;
  try {
    map = load_occupancy_grid(args->map);
  } catch (const std::exception& e) {
    std::cerr << "projtour localize: " << e.what() << "\n";
    return 2;
  }
  mrpt::obs::CRawlog rawlog;
  if (!std::filesystem::exists(args->rawlog) || !rawlog.loadFromRawLogFile(args->rawlog)) {
    std::cerr << "projtour localize: " << args->rawlog << ": cannot read the rawlog\n";
    return 2;
  }

  std::ofstream file;
  if (!args->out.empty()) {
    file.open(args->out);
    if (!file) {
      std::cerr << "projtour localize: " << args->out << ": cannot write\n";
      return 2;
    }
  }
  std::ostream& out = args->out.empty() ? std::cout : file;

  LocalizerOptions options;
  options.particles = args->particles;
  Localizer localizer(*map, options, args->seed);
  localizer.reset(args->init);

  // Odometry arrives either as action collections (increments) or, in observation-only
  // rawlogs, as absolute odometry readings; both become the increment since the last scan.
  Pose2D pending;
  std::optional<Pose2D> last_odometry;
  std::size_t scans = 0, converged_scans = 0;
  double update_s = 0.0;
  Progress progress(rawlog.size());
  auto process_scan = [&](const mrpt::obs::CObservation2DRangeScan& scan) {
    const auto t0 = std::chrono::steady_clock::now();
    localizer.update(pending, scan);
    update_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    pending = Pose2D{};
    const double t_s = scan.timestamp == mrpt::Clock::time_point()
                           ? static_cast<double>(scans)
                           : mrpt::Clock::toDouble(scan.timestamp);
    write_tum(out, t_s, localizer.estimate().mean);
    ++scans;
    if (localizer.converged()) ++converged_scans;
  };
  auto add_odometry = [&](const Pose2D& increment) { pending = pose_compose(pending, increment); };

  try {
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
        case mrpt::obs::CRawlog::etObservation: {
          const auto obs = rawlog.getAsObservation(i);
          if (const auto odo = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(obs)) {
            const Pose2D now{odo->odometry.x(), odo->odometry.y(), odo->odometry.phi()};
            if (last_odometry) add_odometry(pose_delta(*last_odometry, now));
            last_odometry = now;
          } else if (const auto scan =
                         std::dynamic_pointer_cast<mrpt::obs::CObservation2DRangeScan>(obs)) {
            process_scan(*scan);
          }
          break;
        }
        default:
          break;
      }
      progress.update(i + 1, scans);
    }
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
  if (scans == 0) {
    std::cerr << "projtour localize: " << args->rawlog << ": no 2-D laser scans\n";
    return 2;
  }
  const PoseEstimate2D final_estimate = localizer.estimate();
  std::fprintf(stderr,
               "localize: %zu scans, converged for %zu (%.0f%%), final std %.3f m %.2f deg, "
               "scans on the map's walls %.0f%%, %.2f ms per update with %zu particles\n",
               scans, converged_scans, 100.0 * converged_scans / scans,
               position_std_m(final_estimate), rad_to_deg(yaw_std_rad(final_estimate)),
               100.0 * localizer.scan_fit(), 1000.0 * update_s / scans, localizer.particle_count());
  return 0;
}

}  // namespace projtour
