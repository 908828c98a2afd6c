// `projtour localize` over MRPT's localization_demo.rawlog on its map. mrpt-common ships no
// ground truth for this drive (its simplemap was recorded a day earlier), so the check is that
// once converged every scan's endpoints lie on the map's walls at the estimated pose. (Along the
// drive's long corridor the position along it is weakly observable: runs with other seeds agree
// on the walls but may differ by decimetres along the corridor.)
#include <gtest/gtest.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "projtour/localizer.hpp"
#include "projtour/occupancy_map.hpp"
#include "projtour/path_planner.hpp"
#include "projtour_executor/localize_command.hpp"

namespace projtour {
namespace {

const std::string kMap = "/usr/share/mrpt/datasets/localization_demo.simplemap.gz";
const std::string kRawlog = "/usr/share/mrpt/datasets/localization_demo.rawlog";

struct TumPose {
  double t_s;
  Pose2D pose;
};

std::vector<TumPose> read_tum(const std::filesystem::path& file) {
  std::vector<TumPose> out;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    double t, x, y, z, qx, qy, qz, qw;
    EXPECT_TRUE(static_cast<bool>(s >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) << line;
    EXPECT_EQ(z, 0.0);
    EXPECT_NEAR(qx * qx + qy * qy + qz * qz + qw * qw, 1.0, 1e-5);
    out.push_back({t, Pose2D{x, y, 2.0 * std::atan2(qz, qw)}});
  }
  return out;
}

std::filesystem::path run_localize(unsigned seed) {
  const auto out =
      std::filesystem::temp_directory_path() /
      ("projtour_localize_" + std::to_string(::getpid()) + "_" + std::to_string(seed) + ".tum");
  std::vector<std::string> args = {"localize",  "--map",   kMap,     "--rawlog",           kRawlog,
                                   "--init",    "0,0,-57", "--seed", std::to_string(seed), "--out",
                                   out.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  EXPECT_EQ(run_localize_command(static_cast<int>(argv.size()), argv.data()), 0);
  return out;
}

TEST(LocalizeCommand, ConvergesAndStaysOnTheMapOverTheDemoRawlog) {
  const auto trajectory = read_tum(run_localize(1));
  ASSERT_EQ(trajectory.size(), 37u);  // one line per laser scan
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    EXPECT_GT(trajectory[i].t_s, trajectory[i - 1].t_s);
  }

  // Endpoints of each scan, placed with the estimate, against the map's walls.
  const auto map = load_occupancy_grid(kMap);
  const InflatedGrid walls(*map, 0.0);
  mrpt::obs::CRawlog rawlog;
  ASSERT_TRUE(rawlog.loadFromRawLogFile(kRawlog));
  std::size_t scan_index = 0;
  double fit_sum = 0.0;
  std::size_t fit_count = 0;
  for (std::size_t i = 0; i < rawlog.size(); ++i) {
    if (rawlog.getType(i) != mrpt::obs::CRawlog::etSensoryFrame) continue;
    const auto scan =
        rawlog.getAsObservations(i)->getObservationByClass<mrpt::obs::CObservation2DRangeScan>();
    if (!scan) continue;
    const Pose2D pose = trajectory.at(scan_index++).pose;
    const Pose2D sensor = pose_compose(
        pose, Pose2D{scan->sensorPose.x(), scan->sensorPose.y(), scan->sensorPose.yaw()});
    std::size_t on_wall = 0, valid = 0;
    const std::size_t n = scan->getScanSize();
    for (std::size_t k = 0; k < n; k += 4) {
      if (!scan->getScanRangeValidity(k)) continue;
      const double a =
          (scan->rightToLeft ? 1.0 : -1.0) * (-0.5 * scan->aperture + k * scan->aperture / (n - 1));
      const double r = scan->getScanRange(k);
      const Pose2D end = pose_compose(sensor, Pose2D{r * std::cos(a), r * std::sin(a), 0.0});
      int cx = 0, cy = 0;
      ++valid;
      if (walls.cell_of({end.x_m, end.y_m}, cx, cy) && walls.clearance_cell_m(cx, cy) < 0.15) {
        ++on_wall;
      }
    }
    ASSERT_GT(valid, 20u);
    // After the first scans (the guess is rough and the cloud converging), nearly every
    // endpoint lies on a wall.
    const double fraction = static_cast<double>(on_wall) / valid;
    if (scan_index > 10) {
      EXPECT_GT(fraction, 0.85) << "scan " << scan_index;
      fit_sum += fraction;
      ++fit_count;
    }
  }
  ASSERT_GT(fit_count, 20u);
  EXPECT_GT(fit_sum / fit_count, 0.93);
}

TEST(LocalizeCommand, SameSeedSameTrajectory) {
  auto slurp = [](const std::filesystem::path& f) {
    std::ifstream in(f);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string first = slurp(run_localize(3));
  EXPECT_FALSE(first.empty());
  EXPECT_EQ(first, slurp(run_localize(3)));
}

TEST(LocalizeCommand, BadArgumentsAreInvalidInput) {
  std::vector<std::string> args = {"localize", "--map", kMap, "--init", "1,2"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  EXPECT_EQ(run_localize_command(static_cast<int>(argv.size()), argv.data()), 2);
}

}  // namespace
}  // namespace projtour
