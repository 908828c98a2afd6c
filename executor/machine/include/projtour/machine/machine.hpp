#pragma once
// The hierarchical state machine of a tour: its model, loading and checking from YAML, and the
// built-in default machine.
//
// A machine is one root composite. Each state is one of
//   leaf:      behaviour: KIND, params: {...}, timeout_s: S, retries: N, on: {OUTCOME: TARGET}
//   composite: initial: CHILD, states: {NAME: STATE, ...}, for_each: target, on: {done: TARGET}
//   final:     final: true  (entering it completes the enclosing composite)
// A TARGET is a sibling state's name, one of the reserved words skip_target / finish / abort,
// or a retry list of them tried in order, e.g. `poor_fit: [capture, aim, skip_target]`: taking
// a state through a list uses one of that state's `retries` for the current visit (target), and
// a state whose retries are used up is passed over. A plain (non-list) transition never uses
// retries. When every entry of a list is used up the target is skipped (outside a for_each the
// tour aborts), with reason "retries exhausted". The report's `retries` of a target counts the
// retry transitions taken in its visit.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/params.hpp"
#include "projtour/host/diagnostics.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/yaml_reader.hpp"
#include "projtour/machine/catalog.hpp"

namespace projtour {

inline constexpr const char* kSkipTarget = "skip_target";
// Leaves the visit unrecorded and comes back to its target after every other one left; a
// target deferred once is skipped the next time (and when no other target is left).
inline constexpr const char* kDeferTarget = "defer_target";
inline constexpr const char* kFinish = "finish";
inline constexpr const char* kAbort = "abort";
// The one outcome of a composite: it completed (finish, a final child, or all targets visited).
inline constexpr const char* kOutcomeDone = "done";
// The outcome a leaf gets when its timeout_s runs out.
inline constexpr const char* kOutcomeTimeout = "timeout";

bool is_reserved_target(const std::string& name);

struct TransitionSpec {
  std::string outcome;
  std::vector<std::string> targets;  // one, or a retry list
  bool retry = false;                // written as a list: uses the chosen state's retries
  host::SourceMark mark;
  std::string field_path;
};

enum class StateType { leaf, composite, final_state };

struct StateSpec {
  std::string name;
  std::string path;  // "tour/visit/align"
  StateType type = StateType::leaf;
  const StateSpec* parent = nullptr;
  host::SourceMark mark;
  std::string field_path;  // "states.visit.states.align"

  // Leaf.
  std::string behaviour;
  Params params;
  double timeout_s = 0.0;  // 0 = none
  int retries = 0;         // how often retry lists may take this state in one visit
  // The outcome that means the visit's content was shown (`projected_on: succeeded`): a visit
  // interrupted after it is recorded projected, not shown again on resume. Empty = none.
  std::string projected_on;

  // Composite.
  std::string initial;
  bool for_each_target = false;
  // for_each: which target comes next, "mission" (file order) or "nearest" (shortest path on the
  // map from the robot's estimate to the stand-off pose); empty = the mission's `order:`.
  std::string order;
  std::vector<std::unique_ptr<StateSpec>> children;

  std::vector<TransitionSpec> on;

  const TransitionSpec* transition(const std::string& outcome) const;
  const StateSpec* child(const std::string& name) const;
  bool is_leaf() const { return type == StateType::leaf; }
  bool is_composite() const { return type == StateType::composite; }
  // The nearest for_each composite above (or this one), or null.
  const StateSpec* enclosing_for_each() const;
};

class Machine {
 public:
  Machine() = default;
  explicit Machine(std::unique_ptr<StateSpec> root) : root_(std::move(root)) {}

  const StateSpec& root() const { return *root_; }
  // By full path ("tour/visit/align"); null when absent.
  const StateSpec* find(const std::string& path) const;
  // Every state, depth first in declaration order.
  std::vector<const StateSpec*> states() const;
  std::vector<const StateSpec*> leaves() const;

 private:
  std::shared_ptr<StateSpec> root_;
};

// Reads and checks a machine; nullopt when any error was recorded. Every problem found is
// recorded, each with file:line:column and field path: besides the shape, kinds, outcomes and
// targets, no duplicate key, retries from 0 to 100, at most 1000 states nested at most 16
// deep, and the proof that the machine ends: no cycle of plain transitions (a cycle must go
// through a retry list, which the states' retries bound), and every state has a way to
// finish, skip_target, defer_target or abort on outcomes other than `failed`.
std::optional<Machine> load_machine(const host::YamlField& field, const BehaviourCatalog& catalog,
                                    host::Diagnostics& diag);
// `machine:` of a mission: the default, an inline mapping or a file (already read by the loader).
// A mission always has targets, so its machine must also have a for_each: target state.
std::optional<Machine> load_machine(const host::MachineSource& source,
                                    const BehaviourCatalog& catalog, host::Diagnostics& diag);

// The default machine (default_machine.yaml, docs/machine.md) as YAML, parsed by the same loader.
const std::string& default_machine_yaml();
inline constexpr const char* kDefaultMachineFile = "<default machine>";

// Every blackboard key a leaf's kind must read is written, on every path that reaches the leaf,
// by a state before it or by one of the run's services (`service_writes`). A write counts on
// the kind's `succeeded` outcome (on every declared outcome when it has none), and a visit's
// start clears what the states wrote. Readers and writers of one key must agree on its type.
// Each problem is recorded at the reading state's line.
void check_machine_data(const Machine& machine, const BehaviourCatalog& catalog,
                        const std::vector<host::KeyUse>& service_writes, host::Diagnostics& diag);

// Graphviz dot: composites as clusters, reserved targets as terminal nodes, and (with a catalog)
// dotted data edges from each state writing a key to each state reading it.
std::string machine_to_dot(const Machine& machine, const BehaviourCatalog* catalog = nullptr);

}  // namespace projtour
