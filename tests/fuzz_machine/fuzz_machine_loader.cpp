// libFuzzer harness: any text as a state machine's YAML takes the load path of `projtour
// validate` (parse, load_machine with its termination proof, the mission's for_each check,
// check_machine_data) and comes back as a Machine or as diagnostics; never a crash, a sanitizer
// report, a hang or an exception. The loader records every problem and throws nothing, so the
// harness catches nothing: an exception escaping (yaml-cpp's among them) is a finding.
//
// The catalog is fixed and in memory: the tour's kinds with their real outcomes and blackboard
// keys, and a few of each kind's real parameters (every parameter type, read alike by type),
// plus a driver and a service kind, so a machine naming them is judged as a real one is. Loading
// the plugins themselves would mix GCC-built libraries into the sanitized process.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "projtour/machine/machine.hpp"

namespace projtour {
namespace {

const char* const kFile = "machine.yaml";

ParamSpec param(const char* name, ParamType type, const char* default_value) {
  ParamSpec p;
  p.name = name;
  p.type = type;
  p.default_value = default_value;
  return p;
}

host::KeyUse key(const char* name, const char* type, host::KeyAccess access) {
  return {name, type, access};
}

class FixedCatalog : public BehaviourCatalog {
 public:
  FixedCatalog() {
    using T = ParamType;
    const host::KeyAccess r = host::KeyAccess::read, may = host::KeyAccess::read_if_present,
                          w = host::KeyAccess::write;
    const host::KeyUse estimate = key("localization.estimate", "PoseEstimate2D", r);
    behaviour("navigate", {"succeeded", "unreachable", "blocked", "timeout", "lost"},
              {param("tolerance_m", T::number, "0.10"), param("timeout_s", T::number, "600")},
              {estimate, key("localization.converged", "bool", may),
               key("localization.scan", "LaserScan", may), key("align", "AlignResult", may),
               key("navigate", "NavigateResult", w)});
    behaviour("relocalize", {"succeeded", "lost"}, {param("widen_m", T::number, "1.0")},
              {estimate, key("localization.converged", "bool", r),
               key("localization.widen_m", "double", w)});
    behaviour("aim", {"succeeded", "out_of_reach", "reapproach"},
              {param("settle_s", T::number, "0.3"), param("aim_at", T::string, "model_points")},
              {estimate, key("align", "AlignResult", may),
               key("calibration", "ProjectorCalibration", may)});
    behaviour("capture", {"succeeded", "no_frame"}, {param("average_frames", T::integer, "1")},
              {estimate, key("capture", "CapturedFrame", w)});
    behaviour("align", {"succeeded", "poor_fit", "no_target"},
              {param("method", T::string, "projective_icp"), param("min_points", T::integer, "500"),
               param("draw", T::boolean, "true")},
              {key("capture", "CapturedFrame", r), key("align", "AlignResult", may),
               key("align", "AlignResult", w)});
    behaviour(
        "calibrate",
        {"succeeded", "off_screen", "too_few_points", "poor_fit", "no_frame", "blocked_beam",
         "occluded"},
        {param("mask_margin_px", T::integer, "48")},
        {key("align", "AlignResult", r), key("capture", "CapturedFrame", r),
         key("calibration", "ProjectorCalibration", may),
         key("calibration", "ProjectorCalibration", w), key("calibrate", "CalibrateResult", w)});
    behaviour("verify",
              {"verified", "out_of_tolerance", "misaligned", "uncertain", "occluded", "not_seen",
               "off_screen", "no_frame", "blocked_beam"},
              {param("edge_margin_px", T::number, "8"), param("dot_radius_px", T::integer, "10")},
              {key("align", "AlignResult", r), key("capture", "CapturedFrame", r),
               key("calibration", "ProjectorCalibration", may), key("verify", "VerifyResult", w),
               key("align", "AlignResult", w)});
    behaviour("wait", {"succeeded"}, {param("duration_s", T::number, "5")}, {});
    behaviour("project", {"succeeded", "off_screen", "blocked_beam"},
              {param("dwell_s", T::number, "-1"), param("track", T::boolean, "false")},
              {key("align", "AlignResult", r), key("calibration", "ProjectorCalibration", may),
               key("project", "ProjectResult", w)});
    behaviour("next", {"succeeded"}, {}, {});
    // The testing plugin's kind, with its validate(): the one kind here whose values can be
    // refused past their types.
    behaviour("scripted", {"succeeded"},
              {param("outcomes", T::string, "succeeded"), param("ticks", T::integer, "1"),
               param("ignore_cancel", T::boolean, "false"), param("message", T::string, "")},
              {});
    // A kind that declares no outcome of its own can only fail (a dead end to prove).
    behaviour("doomed", {}, {}, {});
    other("sim_base", host::Family::driver);
    other("mrpt_localization", host::Family::service);
  }

  const host::KindInfo* find(const std::string& kind) const override {
    const auto it = kinds_.find(kind);
    return it == kinds_.end() ? nullptr : &it->second;
  }
  std::vector<std::string> kind_names() const override {
    std::vector<std::string> names;
    for (const auto& kv : kinds_) names.push_back(kv.first);
    return names;
  }
  std::string validate_params(const std::string& kind, const Params& params) const override {
    if (kind == "scripted" && params.integer("ticks") < 1) return "ticks must be at least 1";
    return "";
  }
  std::shared_ptr<Behaviour> create_behaviour(const std::string& kind, const Params&,
                                              const RunContext&) const override {
    throw std::logic_error("the machine fuzzer makes no behaviour (" + kind + ")");
  }

 private:
  void behaviour(const char* name, std::vector<std::string> outcomes, std::vector<ParamSpec> params,
                 std::vector<host::KeyUse> keys) {
    host::KindInfo& k = kinds_[name];
    k.name = name;
    k.outcomes = std::move(outcomes);
    k.params = std::move(params);
    k.keys = std::move(keys);
  }
  void other(const char* name, host::Family family) {
    host::KindInfo& k = kinds_[name];
    k.name = name;
    k.family = family;
  }

  std::map<std::string, host::KindInfo> kinds_;
};

// What mrpt_localization writes, the service a run's machine is checked against.
const std::vector<host::KeyUse>& service_writes() {
  static const std::vector<host::KeyUse> kWrites = {
      key("localization.estimate", "PoseEstimate2D", host::KeyAccess::write),
      key("localization.converged", "bool", host::KeyAccess::write),
      key("localization.scan", "LaserScan", host::KeyAccess::write)};
  return kWrites;
}

// The promise of the API: a machine exactly when no error was recorded, every error said.
void check_outcome(bool loaded, const host::Diagnostics& diag) {
  if (loaded == diag.has_errors()) std::abort();
  for (const host::Diagnostic& d : diag.items()) {
    if (d.message.empty()) std::abort();
  }
}

void check_machine(const Machine& machine, const BehaviourCatalog& catalog) {
  for (const StateSpec* s : machine.states()) {
    if (machine.find(s->path) != s) std::abort();
    if (s->is_leaf()) {
      const host::KindInfo* kind = catalog.find(s->behaviour);
      if (kind == nullptr || kind->family != host::Family::behaviour) std::abort();
    }
  }
  host::Diagnostics data;
  check_machine_data(machine, catalog, service_writes(), data);
  if (machine_to_dot(machine, &catalog).rfind("digraph machine {", 0) != 0) std::abort();
}

}  // namespace
}  // namespace projtour

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace projtour;
  static const FixedCatalog catalog;
  const std::string text(reinterpret_cast<const char*>(data), size);

  host::Diagnostics diag;
  const auto node = host::load_yaml_string(text, kFile, diag);
  if (!node) {
    if (!diag.has_errors()) std::abort();
    return 0;
  }
  // A machine file of its own, as `projtour graph` and the tests read one.
  const auto machine = load_machine(host::YamlField(*node, kFile, diag), catalog, diag);
  check_outcome(machine.has_value(), diag);
  if (machine) check_machine(*machine, catalog);

  // The same mapping as a mission's inline `machine:`, which must also visit the targets.
  host::MachineSource source;
  source.is_default = false;
  source.node = *node;
  source.file = kFile;
  source.path = "machine";
  host::Diagnostics mission_diag;
  const auto mission_machine = load_machine(source, catalog, mission_diag);
  check_outcome(mission_machine.has_value(), mission_diag);
  // Where the mapping sits changes the field paths, not the verdict: only the for_each check
  // may tell the two apart.
  if (mission_machine && !machine) std::abort();
  if (machine && !mission_machine &&
      (mission_diag.error_count() != 1 ||
       mission_diag.items().back().message.find("for_each") == std::string::npos)) {
    std::abort();
  }
  return 0;
}
