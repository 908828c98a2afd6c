#pragma once
// Inside the sim plugin: the targets' true bodies. Each target of the mission, where it truly
// stands and what its surface truly is (the mission's mesh plus the model error), and what the
// faults and the referee remember of its visit.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/mission.hpp"
#include "projtour/host/world.hpp"
#include "projtour_sim/depth_renderer.hpp"

namespace projtour::sim {

// One physical object. Targets naming the same model at the same true pose are one object
// visited again (a long day's tour goes back and forth): it is perturbed and rendered once,
// so the world's size follows the objects in the building, not the visits in the mission.
struct TrueObject {
  std::shared_ptr<const perception::TriangleMesh>
      mesh;  // model frame, the true (perturbed) surface
  Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
  int object_id = 0;
  std::string model_key;
  bool missing = false;
  bool shared = false;  // other targets may stand on it: no fault moves or removes it
};

struct TrueTarget {
  const TargetSpec* spec = nullptr;
  std::size_t object = 0;  // index into TrueTargets::objects
  Pose2D standoff;
  int frames_here = 0;
  int shows_here = 0;
  bool kidnapped = false;
  std::optional<double> first_shown_s;  // the projector first lit while this target was active
  bool nudged = false;
  int colour_frames_here = 0;
  // The last frame shown while this target was active, for the referee's pictures. Only the
  // target lit last keeps it raw; the others' are PNG-packed (a long day has hundreds).
  cv::Mat last_frame;
  std::vector<std::uint8_t> last_frame_png;
  Eigen::Isometry3d T_map_camera_shown = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_map_projector_shown = Eigen::Isometry3d::Identity();
  std::optional<double> last_shown_s;
};

// How a fault shapes a target's object: missing (not there at all) and shareable (no fault
// moves or removes it, so another target at the same pose may stand on it).
struct TargetFaultFlags {
  bool missing = false;
  bool shareable = true;
};

struct TrueTargets {
  std::vector<TrueObject> objects;
  std::vector<TrueTarget> targets;
  std::optional<std::size_t> visited;  // index into targets, from set_visited_target
  // The referee's scene of one object alone, built when a truth query needs it: only the
  // object being projected on is ever asked about, so one is kept.
  mutable std::optional<std::pair<std::size_t, Scene>> alone_cache;

  // The mission's targets in order, drawing offsets and surfaces from `setup` (the order of
  // the draws is every run's: see the .cpp).
  void build(const MissionSpec& mission, const host::WorldSpec& world, std::mt19937_64& setup,
             const std::function<TargetFaultFlags(const std::string&)>& flags);

  TrueTarget* find(const std::string& id);
  const TrueTarget* find(const std::string& id) const;
  TrueObject& object(const TrueTarget& t) { return objects[t.object]; }
  const TrueObject& object(const TrueTarget& t) const { return objects[t.object]; }
  const Scene& alone(const TrueTarget& t) const;
  // The target the robot standing at `p` is at: the nearest within reach of its stand-off pose.
  TrueTarget* active(const Pose2D& p);
  // The target's last frame, raw again if it was packed; empty when nothing was shown.
  cv::Mat last_frame(const TrueTarget& t) const;
  void pack_last_frame(TrueTarget& t);
};

// The true surface differs from the robot's model by a smooth field of about `rms_m` along the
// vertex normals: a sum of random plane waves of 4 to 15 cm wavelength, as a Kinect Fusion scan
// differs from the object it was made of.
perception::TriangleMesh perturbed_mesh(const perception::TriangleMesh& mesh, double rms_m,
                                        std::mt19937_64& rng);

}  // namespace projtour::sim
