#pragma once
// The tour's behaviour kinds with the outcomes each declares, as the plugins do: for the
// executor's tests and benchmarks, which play them with scripted behaviours.
#include <map>
#include <string>
#include <vector>

namespace projtour::test {

inline const std::map<std::string, std::vector<std::string>>& tour_kinds() {
  static const std::map<std::string, std::vector<std::string>> kKinds = {
      {"navigate", {"succeeded", "unreachable", "blocked", "timeout", "lost"}},
      {"relocalize", {"succeeded", "lost"}},
      {"aim", {"succeeded", "out_of_reach", "reapproach"}},
      {"capture", {"succeeded", "no_frame"}},
      {"align", {"succeeded", "poor_fit", "no_target"}},
      {"calibrate",
       {"succeeded", "off_screen", "too_few_points", "poor_fit", "no_frame", "blocked_beam",
        "occluded"}},
      {"verify",
       {"verified", "out_of_tolerance", "misaligned", "uncertain", "occluded", "not_seen",
        "off_screen", "no_frame", "blocked_beam"}},
      {"wait", {"succeeded"}},
      {"project", {"succeeded", "off_screen", "blocked_beam"}},
      {"next", {"succeeded"}},
      {"scripted", {"succeeded"}},
  };
  return kKinds;
}

}  // namespace projtour::test
