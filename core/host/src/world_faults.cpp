// The one table of the world file's faults (world_faults.hpp). The defaults are the simulator's;
// the signs are what the loader checks. Documented for users in examples/worlds/atrium_faults.yaml.
#include "projtour/host/world_faults.hpp"

#include <stdexcept>

namespace projtour::host {

namespace {

using S = FaultNumberSign;

std::vector<FaultKindSpec> make_fault_kinds() {
  return {
      {"frame_dropout",
       {{"fraction", S::non_negative, 0.5, "share of depth frames delivered empty"}},
       "depth frames arrive empty (the colour camera's frames all arrive)"},
      {"target_missing", {}, "the target is not there at all"},
      {"occluder",
       {{"distance_m", S::positive, 0.5, "in front of the target, toward its stand-off pose"},
        {"width_m", S::positive, 0.4, "the board's width"},
        {"height_m", S::positive, 0.4, "the board's height"}},
       "a hanging board (above the laser plane) in front of the target"},
      {"blocked_path",
       {{"size_m", S::positive, 0.6, "the box's side"}},
       "a box on the target's stand-off pose (the laser sees it)"},
      {"kidnap",
       {{"distance_m", S::positive, 1.0, "how far the true pose jumps"}},
       "the true pose jumps when the robot arrives"},
      {"camera_disconnect",
       {{"after_frames", S::non_negative, 0.0, "frames grabbed at the target before it fails"}},
       "grab() and grab_colour() throw after that many of their own frames"},
      {"projector_failure",
       {{"after_shows", S::non_negative, 0.0, "shows at the target before the lamp fails"}},
       "show() throws after that many shows"},
      {"target_nudge",
       {{"after_s", S::non_negative, 1.0, "after the projector first lit the target"},
        {"distance_m", S::non_negative, 0.02, "how far the target moves"},
        {"direction_deg", S::any, 90.0, "counter-clockwise from the map's +x"},
        {"dx_m", S::any, 0.0, "the shift along the map's x, instead of distance and direction"},
        {"dy_m", S::any, 0.0, "the shift along the map's y, instead of distance and direction"},
        {"yaw_deg", S::any, 0.0, "turn about the target's own z axis"}},
       "the true target moves once, during the dwell"},
      {"pole",
       {{"distance_m", S::positive, 0.6, "in front of the target, toward its stand-off pose"},
        {"diameter_m", S::positive, 0.05, "the pole's diameter"},
        {"offset_m", S::any, 0.0, "sideways, positive = left seen from the target"}},
       "a vertical pole from the floor to 2 m between the target and the robot"},
      {"daylight",
       {{"lux", S::positive, 20000.0, "the colour camera's room light at the target"}},
       "sunlight floods the target's surroundings while it is the active one"},
      {"person_crossing",
       {{"after_s", S::non_negative, 1.0, "after the projector first lit the target"},
        {"speed_mps", S::positive, 1.0, "walking speed"},
        {"times", S::positive, 1.0, "crossings, each the other way"},
        {"every_s", S::positive, 8.0, "between crossings"},
        {"distance_m", S::positive, 0.45, "in front of the target"}},
       "a person walks across the line from the target to its stand-off pose"},
      {"person_standing",
       {{"after_s", S::non_negative, 1.0, "after the projector first lit the target"},
        {"for_s", S::positive, 10.0, "how long they stand"},
        {"distance_m", S::positive, 0.5, "in front of the target, in the beam"},
        {"offset_m", S::any, 0.0, "sideways, positive = left seen from the target"}},
       "a person walks in from 2.5 m to the side, stands in the beam, and walks off"},
  };
}

}  // namespace

const std::vector<FaultKindSpec>& fault_kinds() {
  static const std::vector<FaultKindSpec> kinds = make_fault_kinds();
  return kinds;
}

const FaultKindSpec* find_fault_kind(const std::string& type) {
  for (const FaultKindSpec& kind : fault_kinds()) {
    if (type == kind.type) return &kind;
  }
  return nullptr;
}

double fault_default(const std::string& type, const std::string& key) {
  if (const FaultKindSpec* kind = find_fault_kind(type)) {
    for (const FaultNumberSpec& n : kind->numbers) {
      if (key == n.key) return n.default_value;
    }
  }
  throw std::logic_error("world faults: " + type + " has no number " + key);
}

double fault_number(const FaultSpec& fault, const std::string& key) {
  const auto it = fault.values.find(key);
  return it == fault.values.end() ? fault_default(fault.type, key) : it->second;
}

}  // namespace projtour::host
