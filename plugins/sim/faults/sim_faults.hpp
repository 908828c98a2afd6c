#pragma once
// Inside the sim plugin: the world file's faults at work. What each fault is, its numbers and
// their defaults are core/host's table (projtour/host/world_faults.hpp); this is what the simulator
// does with them: the static ones (occluder, blocked_path, pole) stand in the building from the
// start, the others act while their target is the active one.
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bodies/robot_body.hpp"
#include "bodies/targets.hpp"
#include "bodies/world_bodies.hpp"
#include "people/crowd.hpp"
#include "projtour/host/world.hpp"

namespace projtour::sim {

class SimFaults {
 public:
  // `faults` must outlive this (the world's copy of the world file).
  explicit SimFaults(const std::vector<host::FaultSpec>& faults) : faults_(&faults) {}

  // The target's fault of that type, or nullptr.
  const host::FaultSpec* find(const std::string& target_id, const std::string& type) const;
  // Whether a fault removes the target's object or moves it (then no other target shares it).
  TargetFaultFlags flags(const std::string& target_id) const;

  // The static faults of every target, in mission order: boards, boxes and poles into the
  // scene's fixed parts, the bumper's obstacles and the grids; and the person faults to come.
  void place(const TrueTargets& targets, WorldBodies& bodies);
  bool any_person_faults() const { return !person_faults_.empty(); }

  // The kidnap: once the robot has arrived (still, within 0.3 m of the stand-off pose), its true
  // pose jumps to a free spot in a seeded direction. Draws from `rng` only when it jumps.
  void kidnap_if_arrived(TrueTarget* active, SimBaseBody& base,
                         const std::function<bool(const Pose2D&)>& collides,
                         std::mt19937_64& rng) const;
  // The nudge, once its time has come: moves the active target's object. True when it moved
  // (the scene must be rebuilt).
  bool nudge_if_due(TrueTarget* active, TrueTargets& targets, double t_s) const;
  // Adds the walkers of every person fault whose time has come. True when any was added.
  bool people_if_due(const TrueTargets& targets, Crowd& crowd, double t_s);

  // The devices' faults at the active target `here` (may be null).
  bool depth_disconnected(const TrueTarget* here) const;
  bool colour_disconnected(const TrueTarget* here) const;
  bool projector_failed(const TrueTarget* here) const;
  // A frame_dropout draws once per frame grabbed at its target.
  bool frame_dropped(const TrueTarget* here, std::mt19937_64& rng) const;
  // The room light at a daylight fault's target, else nullopt.
  std::optional<double> daylight_lux(const TrueTarget* here) const;

 private:
  struct PersonFault {
    std::size_t target = 0;
    const host::FaultSpec* fault = nullptr;
    bool done = false;
  };
  void place_occluder(const host::FaultSpec& f, const TrueTarget& t,
                      const Eigen::Isometry3d& T_map_model, WorldBodies& bodies) const;
  void place_blocked_path(const host::FaultSpec& f, const TrueTarget& t, WorldBodies& bodies) const;
  void place_pole(const host::FaultSpec& f, const TrueTarget& t,
                  const Eigen::Isometry3d& T_map_model, WorldBodies& bodies) const;

  const std::vector<host::FaultSpec>* faults_;
  std::vector<PersonFault> person_faults_;
};

}  // namespace projtour::sim
