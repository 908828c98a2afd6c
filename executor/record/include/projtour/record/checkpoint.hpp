#pragma once
// checkpoint.json: what a run has done, read back by --resume. The checkpoint is input like any
// other: it is checked against the mission before anything moves, and a done target whose pose
// or model changed since is visited again.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/mission.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/record/target_record.hpp"

namespace projtour {

// Bounds of a checkpoint no tour could reach (README.md, "The command"). Its records are a
// kilobyte or two each: 64 MiB holds tens of thousands of targets.
constexpr std::uintmax_t kMaxCheckpointBytes = 64u << 20;
// 10^9 s is 31 years of mission time; a double still resolves a 1 ms tick there, which it no
// longer does near 1e300 (the clock stood still and the tour never ended).
constexpr double kMaxCheckpointMissionS = 1e9;
// A done target counts as done against the mission only within these of its recorded pose.
constexpr double kIdentityTolerance_m = 1e-3;
constexpr double kIdentityTolerance_deg = 0.01;

// What a target was done against, recorded with its record: its pose on the map and its model
// file's content. The model is identified by its size and 64-bit FNV-1a hash, not its path: a
// model moved or renamed but byte for byte the same is the same model; the path is kept for the
// note only.
struct TargetIdentity {
  Eigen::Vector3d t_map_model_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_map_model = Eigen::Quaterniond::Identity();
  std::string model;
  std::uint64_t model_bytes = 0;
  std::uint64_t model_fnv1a64 = 0;
};

// Reads the target's model file through. Throws std::runtime_error naming a file it cannot read.
TargetIdentity identify_target(const TargetSpec& target);
// identify_target of every target, in mission order.
std::vector<TargetIdentity> identify_targets(const MissionSpec& mission);
// Empty when `now` is `recorded` within the tolerances; otherwise why the target is not the one
// that was done ("its pose on the map moved 24.000 m", "its model ... changed").
std::string identity_change(const TargetIdentity& recorded, const TargetIdentity& now);

struct Checkpoint {
  std::string mission;
  std::uint64_t seed = 1;
  double mission_s = 0.0;
  std::vector<TargetRecord> done;  // indices resolved against the mission; each target once
  // done_against[k] is what done[k] was done against: written within done[k]
  // ("done_against"), so both always have the same size.
  std::vector<TargetIdentity> done_against;
  std::optional<std::string> current_target;  // the visit an interruption cut short
  // The schedule's round the run was in (written only for a mission with a schedule); done
  // records of earlier rounds are history, those of this round are not visited again.
  std::optional<int> round;
};

// Throws std::logic_error when done and done_against differ in size.
Json checkpoint_to_json(const Checkpoint& checkpoint);

// Parses strictly (json_io.hpp, at most kMaxJsonDepth deep) and checks the checkpoint against
// the mission: its name, finite non-negative times (mission_s at most kMaxCheckpointMissionS),
// each done target in the mission and at most once, with an outcome the executor writes
// (kTargetOutcomes) and what it was done against. Throws std::runtime_error
// "SOURCE: json.path: what was expected" (or parse_json's "SOURCE: malformed JSON at byte N").
Checkpoint parse_checkpoint(const std::string& text, const std::string& source,
                            const MissionSpec& mission);
// parse_checkpoint of the file, refused unread above kMaxCheckpointBytes.
Checkpoint read_checkpoint(const std::filesystem::path& file, const MissionSpec& mission);

// Takes out of checkpoint.done every target whose identity differs from `now` (identify_targets
// of the mission being resumed), to be visited again; returns one note per target saying why.
std::vector<std::string> drop_changed_targets(Checkpoint& checkpoint,
                                              const std::vector<TargetIdentity>& now);

}  // namespace projtour
