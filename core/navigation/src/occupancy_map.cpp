#include "projtour/navigation/occupancy_map.hpp"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/serialization/CArchive.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "projtour/navigation/path_planner.hpp"

namespace projtour::navigation {

namespace {

using mrpt::maps::COccupancyGridMap2D;
namespace fs = std::filesystem;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

[[noreturn]] void fail_at(const fs::path& file, const YAML::Node& node, const std::string& field,
                          const std::string& message) {
  std::string where = file.string();
  if (node.IsDefined() && !node.Mark().is_null()) {
    where +=
        ":" + std::to_string(node.Mark().line + 1) + ":" + std::to_string(node.Mark().column + 1);
  }
  throw std::runtime_error(where + ": " + field + ": " + message);
}

double as_number(const fs::path& file, const YAML::Node& node, const std::string& field) {
  try {
    const double value = node.as<double>();
    if (std::isfinite(value)) return value;
  } catch (const YAML::Exception&) {
  }
  fail_at(file, node, field, "expected a number");
}

std::string number_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double read_double(const fs::path& file, const YAML::Node& root, const std::string& key,
                   std::optional<double> fallback) {
  const YAML::Node node = root[key];
  if (!node.IsDefined()) {
    if (fallback) return *fallback;
    throw std::runtime_error(file.string() + ": missing \"" + key + "\" (ROS map_server YAML)");
  }
  return as_number(file, node, key);
}

// yaml-cpp keeps the first of two equal keys without a word; map_server takes the last.
void check_unique_keys(const fs::path& file, const YAML::Node& root) {
  std::map<std::string, int> first_line;
  for (const auto& kv : root) {
    if (!kv.first.IsScalar()) continue;
    const auto [it, inserted] = first_line.emplace(kv.first.Scalar(), kv.first.Mark().line + 1);
    if (!inserted) {
      fail_at(file, kv.first, kv.first.Scalar(),
              "duplicate key \"" + kv.first.Scalar() + "\" (first at line " +
                  std::to_string(it->second) + ")");
    }
  }
}

// The Malaga campus map is 1888 x 2738 cells; 100 million cells (10 km^2 at 5 cm) is beyond
// any building a tour is held in, and a gigabyte of grid is not a map but a mistake.
constexpr long long kMaxMapCells = 100'000'000;

// ROS map_server: image + resolution + origin [x, y, yaw], thresholds on occupancy probability.
std::shared_ptr<COccupancyGridMap2D> load_ros_yaml(const fs::path& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::ParserException& e) {
    throw std::runtime_error(file.string() + ":" + std::to_string(e.mark.line + 1) + ":" +
                             std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  if (!root.IsMap())
    throw std::runtime_error(file.string() + ": expected a ROS map_server mapping");
  check_unique_keys(file, root);
  const YAML::Node image_node = root["image"];
  if (!image_node.IsDefined() || !image_node.IsScalar()) {
    throw std::runtime_error(file.string() + ": missing \"image\" (ROS map_server YAML)");
  }
  fs::path image = image_node.as<std::string>();
  if (image.is_relative()) image = file.parent_path() / image;
  const double resolution_m = read_double(file, root, "resolution", std::nullopt);
  if (!(resolution_m > 0.0)) fail_at(file, root["resolution"], "resolution", "must be positive");
  const YAML::Node origin = root["origin"];
  if (!origin.IsSequence() || origin.size() < 2) {
    fail_at(file, origin, "origin", "expected [x, y, yaw]");
  }
  const double origin_x_m = as_number(file, origin[0], "origin[0]");
  const double origin_y_m = as_number(file, origin[1], "origin[1]");
  const double origin_yaw = origin.size() > 2 ? as_number(file, origin[2], "origin[2]") : 0.0;
  if (std::abs(origin_yaw) > 1e-9) {
    fail_at(file, origin, "origin", "a rotated map (yaw != 0) is not supported");
  }
  const bool negate = read_double(file, root, "negate", 0.0) != 0.0;
  const double occupied_thresh = read_double(file, root, "occupied_thresh", 0.65);
  const double free_thresh = read_double(file, root, "free_thresh", 0.196);
  if (free_thresh < 0.0) fail_at(file, root["free_thresh"], "free_thresh", "must be >= 0");
  if (occupied_thresh > 1.0) {
    fail_at(file, root["occupied_thresh"], "occupied_thresh", "must be <= 1");
  }
  if (!(free_thresh < occupied_thresh)) {
    const YAML::Node where =
        root["occupied_thresh"].IsDefined() ? root["occupied_thresh"] : root["free_thresh"];
    fail_at(file, where, root["occupied_thresh"].IsDefined() ? "occupied_thresh" : "free_thresh",
            "expected free_thresh < occupied_thresh, got free_thresh " + number_text(free_thresh) +
                " and occupied_thresh " + number_text(occupied_thresh));
  }
  const std::string mode =
      root["mode"].IsDefined() ? lower(root["mode"].as<std::string>()) : "trinary";
  if (mode != "trinary" && mode != "scale" && mode != "raw") {
    fail_at(file, root["mode"], "mode", "expected trinary, scale or raw, got \"" + mode + "\"");
  }

  const cv::Mat pixels = cv::imread(image.string(), cv::IMREAD_GRAYSCALE);
  if (pixels.empty()) {
    fail_at(file, image_node, "image", "cannot read the image \"" + image.string() + "\"");
  }
  if (static_cast<long long>(pixels.cols) * pixels.rows > kMaxMapCells) {
    fail_at(file, image_node, "image",
            "the image is " + std::to_string(pixels.cols) + " x " + std::to_string(pixels.rows) +
                " pixels; a map has at most " + std::to_string(kMaxMapCells) + " cells");
  }
  auto map = std::make_shared<COccupancyGridMap2D>();
  const double width_m = pixels.cols * resolution_m, height_m = pixels.rows * resolution_m;
  map->setSize(static_cast<float>(origin_x_m), static_cast<float>(origin_x_m + width_m),
               static_cast<float>(origin_y_m), static_cast<float>(origin_y_m + height_m),
               static_cast<float>(resolution_m), 0.5f);
  const int nx = std::min<int>(pixels.cols, static_cast<int>(map->getSizeX()));
  const int ny = std::min<int>(pixels.rows, static_cast<int>(map->getSizeY()));
  for (int row = 0; row < ny; ++row) {
    // Image row 0 is the top of the map (largest y).
    const int cy = pixels.rows - 1 - row;
    if (cy >= ny) continue;
    for (int cx = 0; cx < nx; ++cx) {
      const int value = pixels.at<std::uint8_t>(row, cx);
      float free_p = 0.5f;
      if (mode == "raw") {
        free_p = value >= 0 && value <= 100 ? 1.0f - value / 100.0f : 0.5f;
      } else {
        const double occupancy = negate ? value / 255.0 : (255.0 - value) / 255.0;
        if (occupancy > occupied_thresh) {
          free_p = 0.0f;
        } else if (occupancy < free_thresh) {
          free_p = 1.0f;
        } else if (mode == "scale") {
          free_p =
              static_cast<float>(1.0 - (occupancy - free_thresh) / (occupied_thresh - free_thresh));
        }
      }
      map->setCell(cx, cy, free_p);
    }
  }
  return map;
}

std::shared_ptr<COccupancyGridMap2D> load_gridmap(const fs::path& file) {
  auto map = std::make_shared<COccupancyGridMap2D>();
  try {
    mrpt::io::CFileGZInputStream stream(file.string());
    auto archive = mrpt::serialization::archiveFrom(stream);
    archive >> *map;
  } catch (const std::exception& e) {
    throw std::runtime_error(file.string() + ": not a readable MRPT gridmap: " + e.what());
  }
  return map;
}

// A simple map (poses + scans) is rendered into a fresh grid, as MRPT's pf-localization does.
std::shared_ptr<COccupancyGridMap2D> load_simplemap(const fs::path& file) {
  mrpt::maps::CSimpleMap simple_map;
  try {
    mrpt::io::CFileGZInputStream stream(file.string());
    auto archive = mrpt::serialization::archiveFrom(stream);
    archive >> simple_map;
  } catch (const std::exception& e) {
    throw std::runtime_error(file.string() + ": not a readable MRPT simplemap: " + e.what());
  }
  auto map = std::make_shared<COccupancyGridMap2D>(-10.0f, 10.0f, -10.0f, 10.0f, 0.05f);
  // Crisper than pf-localization's 0.55: free space must read as free up to the walls.
  map->insertionOptions.maxOccupancyUpdateCertainty = 0.8f;
  map->insertionOptions.maxDistanceInsertion = 15.0f;
  map->insertionOptions.considerInvalidRangesAsFreeSpace = true;
  map->loadFromSimpleMap(simple_map);
  return map;
}

std::string format_xy(double x, double y) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.2f, %.2f)", x, y);
  return buffer;
}

std::string format_m(double v) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.2f m", v);
  return buffer;
}

// Why a pose is no place for the robot, or "" when it fits.
std::string placement_problem(const COccupancyGridMap2D& map, const InflatedGrid& grid,
                              const Eigen::Vector2d& p_m) {
  if (!grid.contains(p_m)) return "is outside the map";
  if (!grid.is_free_space(p_m)) {
    const float free_p = map.getPos(static_cast<float>(p_m.x()), static_cast<float>(p_m.y()));
    return free_p < 0.5f ? "is in an occupied cell" : "is in an unknown cell";
  }
  if (!grid.fits(p_m)) {
    return "is closer than the robot's radius (" + format_m(grid.robot_radius_m()) +
           ") to an obstacle";
  }
  return "";
}

}  // namespace

std::shared_ptr<COccupancyGridMap2D> load_occupancy_grid(const fs::path& file) {
  if (!fs::exists(file)) throw std::runtime_error(file.string() + ": no such map file");
  const std::string name = lower(file.filename().string());
  if (ends_with(name, ".yaml") || ends_with(name, ".yml")) return load_ros_yaml(file);
  if (ends_with(name, ".gridmap") || ends_with(name, ".gridmap.gz")) return load_gridmap(file);
  if (ends_with(name, ".simplemap") || ends_with(name, ".simplemap.gz")) {
    return load_simplemap(file);
  }
  throw std::runtime_error(file.string() +
                           ": unknown map format (expected ROS map_server .yaml, .gridmap, "
                           ".gridmap.gz, .simplemap or .simplemap.gz)");
}

void save_occupancy_grid_yaml(const COccupancyGridMap2D& map, const fs::path& yaml_file) {
  const int nx = static_cast<int>(map.getSizeX()), ny = static_cast<int>(map.getSizeY());
  cv::Mat pixels(ny, nx, CV_8UC1);
  for (int cy = 0; cy < ny; ++cy) {
    for (int cx = 0; cx < nx; ++cx) {
      const float free_p = map.getCell(cx, cy);
      // Thresholds mirror the YAML's so the file reads back to the same three classes.
      const std::uint8_t value = free_p > kFreeCellThreshold ? 254 : (free_p < 0.35f ? 0 : 205);
      pixels.at<std::uint8_t>(ny - 1 - cy, cx) = value;
    }
  }
  fs::path image = yaml_file;
  image.replace_extension(".png");
  if (!cv::imwrite(image.string(), pixels)) {
    throw std::runtime_error(image.string() + ": cannot write the map image");
  }
  std::ofstream out(yaml_file);
  char origin[128];
  std::snprintf(origin, sizeof origin, "[%.6g, %.6g, 0.0]", map.getXMin(), map.getYMin());
  out << "image: " << image.filename().string() << "\n"
      << "resolution: " << map.getResolution() << "\n"
      << "origin: " << origin << "\n"
      << "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  if (!out) throw std::runtime_error(yaml_file.string() + ": cannot write");
}

Pose2D standoff_pose(const TargetSpec& target) {
  const Eigen::Vector3d front = target.T_map_model.linear().col(0);
  Eigen::Vector2d direction(front.x(), front.y());
  // A model whose +x points straight up or down has no front on the floor; use its +z's
  // horizontal part then, which is where such a model faces after a pitch of 90 degrees.
  if (direction.norm() < 1e-6) {
    const Eigen::Vector3d up = target.T_map_model.linear().col(2);
    direction = Eigen::Vector2d(-up.x(), -up.y());
    if (direction.norm() < 1e-6) direction = Eigen::Vector2d::UnitX();
  }
  direction.normalize();
  const Eigen::Vector2d centre = target.T_map_model.translation().head<2>();
  const Eigen::Vector2d position = centre + target.standoff_m * direction;
  return Pose2D{position.x(), position.y(), std::atan2(-direction.y(), -direction.x())};
}

std::vector<MapProblem> check_mission_on_map(const MissionSpec& mission,
                                             const COccupancyGridMap2D& map) {
  std::vector<MapProblem> problems;
  const PathPlanner planner(map, mission.robot.base.radius_m);
  const InflatedGrid& grid = planner.grid();
  char bounds[160];
  std::snprintf(bounds, sizeof bounds, "(x %.2f..%.2f, y %.2f..%.2f)", map.getXMin(), map.getXMax(),
                map.getYMin(), map.getYMax());

  const Eigen::Vector2d start(mission.start.x_m, mission.start.y_m);
  bool start_ok = true;
  if (!grid.contains(start)) {
    problems.push_back(
        {"start", "start",
         "start pose " + format_xy(start.x(), start.y()) + " is outside the map " + bounds});
    start_ok = false;
  } else if (!grid.is_free_space(start)) {
    problems.push_back({"start", "start",
                        "start pose " + format_xy(start.x(), start.y()) + " " +
                            placement_problem(map, grid, start)});
    start_ok = false;
  }
  std::optional<PathPlanner::Reachable> reachable;
  if (start_ok) {
    reachable = planner.reachable_from(start);
    if (reachable->empty()) {
      problems.push_back({"start", "start",
                          "start pose " + format_xy(start.x(), start.y()) +
                              " leaves no room for the robot's radius (" +
                              format_m(grid.robot_radius_m()) + ")"});
      start_ok = false;
    }
  }

  for (std::size_t i = 0; i < mission.targets.size(); ++i) {
    const TargetSpec& target = mission.targets[i];
    const std::string prefix = "targets[" + std::to_string(i) + "]";
    const Eigen::Vector2d centre = target.T_map_model.translation().head<2>();
    if (!grid.contains(centre)) {
      problems.push_back(
          {prefix + ".pose", prefix + ".pose",
           "target " + format_xy(centre.x(), centre.y()) + " is outside the map " + bounds});
      continue;
    }
    const std::string standoff_path = prefix + ".standoff_m";
    const Pose2D standoff = standoff_pose(target);
    const Eigen::Vector2d p(standoff.x_m, standoff.y_m);
    const std::string problem = placement_problem(map, grid, p);
    if (!problem.empty()) {
      problems.push_back({standoff_path, prefix + ".pose",
                          "stand-off pose " + format_xy(p.x(), p.y()) + " " + problem});
    } else if (start_ok && !reachable->contains(p)) {
      problems.push_back(
          {standoff_path, prefix + ".pose",
           "stand-off pose " + format_xy(p.x(), p.y()) + " is not reachable from the start"});
    }
  }
  return problems;
}

}  // namespace projtour::navigation
