#pragma once
// The mission as every plugin sees it: targets, map, start and the robot. What only the loader
// and the executor need (where each field was written, the machine's YAML, the robot file's
// driver choices) lives in the host library's LoadedMission.
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/robot.hpp"

namespace projtour {

struct TargetSpec {
  std::string id;
  std::filesystem::path model;
  Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
  // Corners of the projection area in the model frame: top-left, top-right, bottom-right,
  // bottom-left (the content image's corners go to them in this order).
  std::array<Eigen::Vector3d, 4> model_points;
  std::filesystem::path content;
  double standoff_m = 1.0;
  double dwell_s = 10.0;
  // A visit counts as projected only when the colour camera sees the content's corners land
  // within this of the Model Points (verify's gate).
  double tolerance_mm = 3.0;
};

struct MissionSpec {
  std::string name;
  std::filesystem::path file;
  std::filesystem::path map;
  std::filesystem::path robot_file;
  Pose2D start;
  std::vector<TargetSpec> targets;
  std::string order = "mission";  // "mission" | "nearest"
  RobotSpec robot;
};

}  // namespace projtour
