// libFuzzer harness: any text through parse_checkpoint must come back as a Checkpoint that keeps
// every promise --resume relies on, or as a std::runtime_error naming the file; never a crash, a
// sanitizer report, a hang or another exception (an nlohmann exception escaping is a finding).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <stdexcept>
#include <string>

#include "projtour/record/checkpoint.hpp"

namespace {

const char* const kSource = "checkpoint.json";

// The seed corpus's mission: "minimal" with its rabbit, and two more targets.
projtour::MissionSpec make_mission() {
  projtour::MissionSpec mission;
  mission.name = "minimal";
  for (const char* id : {"rabbit", "pillar", "sign"}) {
    projtour::TargetSpec t;
    t.id = id;
    mission.targets.push_back(t);
  }
  return mission;
}

// What the mission's targets are now: rabbit as the seed checkpoints recorded it, so that
// drop_changed_targets both keeps and drops.
std::vector<projtour::TargetIdentity> make_identities() {
  std::vector<projtour::TargetIdentity> now(3);
  now[0].t_map_model_m = {-8.04, -23.16, 0.9};
  now[0].model = "examples/models/bunny.ply";
  now[0].model_bytes = 108606;
  now[0].model_fnv1a64 = 0x7692f47fa28a2eecull;
  return now;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const projtour::MissionSpec mission = make_mission();
  static const std::vector<projtour::TargetIdentity> now = make_identities();
  const std::string text(reinterpret_cast<const char*>(data), size);

  projtour::Checkpoint c;
  try {
    c = projtour::parse_checkpoint(text, kSource, mission);
  } catch (const std::runtime_error& e) {
    // Every refusal names the file, for the operator to find it.
    if (std::string(e.what()).rfind(std::string(kSource) + ": ", 0) != 0) std::abort();
    return 0;
  }
  // The promises of a checkpoint that reads.
  if (!std::isfinite(c.mission_s) || c.mission_s < 0.0 ||
      c.mission_s > projtour::kMaxCheckpointMissionS) {
    std::abort();
  }
  if (c.done.size() != c.done_against.size() || c.done.size() > mission.targets.size()) {
    std::abort();
  }
  std::set<std::size_t> seen;
  for (const auto& r : c.done) {
    if (r.index >= mission.targets.size() || mission.targets[r.index].id != r.id) std::abort();
    if (!seen.insert(r.index).second) std::abort();
    bool known = false;
    for (const char* o : projtour::kTargetOutcomes) known = known || r.outcome == o;
    if (!known) std::abort();
  }
  // What it writes back reads back, to the same text.
  const std::string written = projtour::dump_json(projtour::checkpoint_to_json(c), 2);
  const projtour::Checkpoint again = projtour::parse_checkpoint(written, kSource, mission);
  if (projtour::dump_json(projtour::checkpoint_to_json(again), 2) != written) std::abort();
  projtour::Checkpoint resumed = again;
  const auto notes = projtour::drop_changed_targets(resumed, now);
  if (resumed.done.size() + notes.size() != again.done.size()) std::abort();
  return 0;
}
