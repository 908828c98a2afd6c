#include "projtour/machine/machine.hpp"

#include <algorithm>
#include <functional>
#include <map>
#include <set>

#include "projtour/host/params_reader.hpp"

namespace projtour {

bool is_reserved_target(const std::string& name) {
  return name == kSkipTarget || name == kDeferTarget || name == kFinish || name == kAbort;
}

const TransitionSpec* StateSpec::transition(const std::string& outcome) const {
  for (const auto& t : on) {
    if (t.outcome == outcome) return &t;
  }
  return nullptr;
}

const StateSpec* StateSpec::child(const std::string& child_name) const {
  for (const auto& c : children) {
    if (c->name == child_name) return c.get();
  }
  return nullptr;
}

const StateSpec* StateSpec::enclosing_for_each() const {
  for (const StateSpec* s = this; s != nullptr; s = s->parent) {
    if (s->for_each_target) return s;
  }
  return nullptr;
}

const StateSpec* Machine::find(const std::string& path) const {
  for (const StateSpec* s : states()) {
    if (s->path == path) return s;
  }
  return nullptr;
}

std::vector<const StateSpec*> Machine::states() const {
  std::vector<const StateSpec*> out;
  if (!root_) return out;
  std::function<void(const StateSpec&)> walk = [&](const StateSpec& s) {
    out.push_back(&s);
    for (const auto& c : s.children) walk(*c);
  };
  walk(*root_);
  return out;
}

std::vector<const StateSpec*> Machine::leaves() const {
  std::vector<const StateSpec*> out;
  for (const StateSpec* s : states()) {
    if (s->is_leaf()) out.push_back(s);
  }
  return out;
}

namespace {

// Bounds no real tour comes near (the default machine: 12 states, 2 levels, 3 retries), so a
// machine beyond them is a mistake or an attack (YAML aliases can multiply states), not a tour.
constexpr int kMaxRetries = 100;
constexpr std::size_t kMaxStates = 1000;
constexpr int kMaxNesting = 16;

host::SourceMark key_mark(const YAML::Node& key, const host::YamlField& parent) {
  const YAML::Mark m = key.Mark();
  if (m.is_null() || m.line < 0) return parent.mark();
  return host::SourceMark{parent.file(), m.line + 1, m.column + 1};
}

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

// yaml-cpp keeps the first of two equal keys and drops the second without a word; every map
// of the machine (params included) is checked here. A node reached twice through an alias is
// walked once, by its mark, so nested aliases cannot make the walk exponential.
void check_unique_keys_deep(const YAML::Node& node, const std::string& path,
                            const std::string& file, host::Diagnostics& diag,
                            std::set<std::pair<int, int>>& walked) {
  if (!node.IsMap() && !node.IsSequence()) return;
  const YAML::Mark m = node.Mark();
  if (!m.is_null() && !walked.insert({m.line, m.column}).second) return;
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      check_unique_keys_deep(node[i], path + "[" + std::to_string(i) + "]", file, diag, walked);
    }
    return;
  }
  std::map<std::string, int> first_line;
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) continue;
    const std::string& key = kv.first.Scalar();
    const std::string child = path.empty() ? key : path + "." + key;
    const YAML::Mark k = kv.first.Mark();
    const auto [it, inserted] = first_line.emplace(key, k.line + 1);
    if (!inserted) {
      diag.error(
          host::SourceMark{file, k.line + 1, k.column + 1}, child,
          "duplicate key \"" + key + "\" (first at line " + std::to_string(it->second) + ")");
    }
    check_unique_keys_deep(kv.second, child, file, diag, walked);
  }
}

// The proof that a machine ends: states and composites' completions are the nodes of a graph
// whose edges are the transitions. Leaving a visit (skip_target, defer_target, a for_each body
// completing), abort and the root completing end the walk; a visit ends at most twice per
// target (a deferred target is skipped the next time). A retry list is bounded by the
// retries of the states it names, which only a new visit restores, and its exhaustion skips
// the target or aborts. So the machine ends exactly when no cycle is made of plain
// transitions alone; and it must not count on `failed` to leave (a behaviour that keeps
// succeeding must lead somewhere too).
class TerminationCheck {
 public:
  TerminationCheck(const StateSpec& root, host::Diagnostics& diag) : diag_(diag) {
    add_nodes(root);
    for (std::size_t n = 0; n < nodes_.size(); ++n) add_edges(n);
  }

  void run() {
    const std::vector<int> component = components();
    std::vector<bool> can_leave = leaves_without_failed();
    // One report per cycle, at a transition of it (entering a composite is not written down).
    std::set<int> reported;
    for (const bool written : {true, false}) {
      for (std::size_t n = 0; n < nodes_.size(); ++n) {
        for (const Edge& e : nodes_[n].edges) {
          if (e.to < 0 || e.retry || (written && e.transition == nullptr)) continue;
          const int c = component[n];
          if (component[e.to] != c || !reported.insert(c).second) continue;
          report_cycle(static_cast<int>(n), e, component, can_leave);
        }
      }
    }
    for (std::size_t n = 0; n < nodes_.size(); ++n) {
      const Node& node = nodes_[n];
      if (can_leave[n] || node.completion) continue;
      bool dead_end = true;
      for (const Edge& e : node.edges) dead_end = dead_end && e.failed;
      if (!dead_end) continue;  // it leads into a dead end or a cycle, reported there
      diag_.error(node.state->mark, node.state->field_path,
                  "every way out of \"" + name(static_cast<int>(n)) +
                      "\" is \"failed\": it needs a transition on another outcome that leads "
                      "to finish, skip_target, defer_target or abort");
    }
  }

 private:
  // to < 0: the edge ends the walk (a visit left, abort, the tour done).
  struct Edge {
    int to;
    const TransitionSpec* transition;  // null for entering a composite or a final state
    bool retry;
    bool failed;
  };
  struct Node {
    const StateSpec* state;
    bool completion;  // the composite `state` completing, not entering it
    std::vector<Edge> edges;
  };

  void add_nodes(const StateSpec& s) {
    enter_[&s] = static_cast<int>(nodes_.size());
    nodes_.push_back({&s, false, {}});
    if (!s.is_composite()) return;
    complete_[&s] = static_cast<int>(nodes_.size());
    nodes_.push_back({&s, true, {}});
    for (const auto& c : s.children) add_nodes(*c);
  }

  // Where completing `composite` leads: its completion node, or the end of a visit or tour.
  int completion_of(const StateSpec& composite) const {
    if (composite.for_each_target || composite.parent == nullptr) return -1;
    return complete_.at(&composite);
  }

  void add_edges(std::size_t n) {
    Node& node = nodes_[n];
    const StateSpec& s = *node.state;
    if (s.type == StateType::final_state) {
      node.edges.push_back({completion_of(*s.parent), nullptr, false, false});
      return;
    }
    if (s.is_composite() && !node.completion) {
      if (const StateSpec* initial = s.child(s.initial)) {
        node.edges.push_back({enter_.at(initial), nullptr, false, false});
      }
      // A for_each completes once no target is left.
      if (s.for_each_target) node.edges.push_back({complete_.at(&s), nullptr, false, false});
      return;
    }
    if (s.parent == nullptr) return;  // the root completing ends the tour
    for (const auto& t : s.on) {
      const bool failed = t.outcome == kOutcomeFailed;
      for (const auto& target : t.targets) {
        int to = -1;
        if (target == kFinish) {
          to = completion_of(*s.parent);
        } else if (const StateSpec* sibling = s.parent->child(target)) {
          to = enter_.at(sibling);
        }
        node.edges.push_back({to, &t, t.retry, failed});
      }
    }
  }

  // Strongly connected components of the plain edges (Tarjan's, iteratively: a machine may
  // hold up to kMaxStates states). A component with an edge inside it is a plain cycle.
  std::vector<int> components() const {
    const int count = static_cast<int>(nodes_.size());
    std::vector<int> index(count, -1), low(count, 0), component(count, -1);
    std::vector<bool> on_stack(count, false);
    std::vector<int> stack;
    int next_index = 0, next_component = 0;
    for (int start = 0; start < count; ++start) {
      if (index[start] >= 0) continue;
      std::vector<std::pair<int, std::size_t>> work{{start, 0}};
      index[start] = low[start] = next_index++;
      stack.push_back(start);
      on_stack[start] = true;
      while (!work.empty()) {
        auto& [v, edge] = work.back();
        const auto& edges = nodes_[v].edges;
        if (edge < edges.size()) {
          const Edge& e = edges[edge++];
          if (e.to < 0 || e.retry) continue;
          if (index[e.to] < 0) {
            index[e.to] = low[e.to] = next_index++;
            stack.push_back(e.to);
            on_stack[e.to] = true;
            work.push_back({e.to, 0});
          } else if (on_stack[e.to]) {
            low[v] = std::min(low[v], index[e.to]);
          }
          continue;
        }
        const int done = v;
        work.pop_back();
        if (!work.empty()) low[work.back().first] = std::min(low[work.back().first], low[done]);
        if (low[done] != index[done]) continue;
        for (int w = -1; w != done;) {
          w = stack.back();
          stack.pop_back();
          on_stack[w] = false;
          component[w] = next_component;
        }
        ++next_component;
      }
    }
    return component;
  }

  // Which nodes reach the end of a visit or of the tour on outcomes other than `failed`. A
  // retry list ends one by itself: used up, it skips the target or aborts.
  std::vector<bool> leaves_without_failed() const {
    std::vector<bool> can(nodes_.size(), false);
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t n = 0; n < nodes_.size(); ++n) {
        if (can[n]) continue;
        for (const Edge& e : nodes_[n].edges) {
          if (e.failed || !(e.to < 0 || e.retry || can[e.to])) continue;
          can[n] = changed = true;
          break;
        }
      }
    }
    return can;
  }

  void report_cycle(int from, const Edge& closing, const std::vector<int>& component,
                    const std::vector<bool>& can_leave) {
    // The way back from the edge's end to its start, inside the component (breadth first).
    std::map<int, int> came_from{{closing.to, closing.to}};
    std::vector<int> todo{closing.to};
    for (std::size_t i = 0; i < todo.size() && came_from.count(from) == 0; ++i) {
      for (const Edge& e : nodes_[todo[i]].edges) {
        if (e.to < 0 || e.retry || component[e.to] != component[from]) continue;
        if (came_from.emplace(e.to, todo[i]).second) todo.push_back(e.to);
      }
    }
    std::vector<int> loop{from};
    for (int n = from; n != closing.to;) loop.push_back(n = came_from.at(n));
    std::string names = name(from);
    for (auto it = loop.rbegin(); it != loop.rend(); ++it) names += " -> " + name(*it);
    bool trapped = true;
    for (int n : loop) trapped = trapped && !can_leave[n];
    const StateSpec& s = *nodes_[from].state;
    const TransitionSpec* t = closing.transition;
    std::string message = "the plain transitions " + names +
                          " form a cycle that can repeat forever; make one of them a retry list "
                          "(e.g. [" +
                          name(closing.to) + ", skip_target]) so retries bound it";
    if (trapped) message += ", and give the cycle a way out on an outcome other than \"failed\"";
    if (t != nullptr) {
      diag_.error(t->mark, t->field_path, message);
    } else {
      diag_.error(s.mark, s.field_path, message);
    }
  }

  // The state's path without the root's name ("visit/align"); a completion as "visit (done)".
  std::string name(int n) const {
    const Node& node = nodes_[n];
    const std::string& path = node.state->path;
    const std::size_t slash = path.find('/');
    std::string out = slash == std::string::npos ? path : path.substr(slash + 1);
    return node.completion ? out + " (done)" : out;
  }

  host::Diagnostics& diag_;
  std::vector<Node> nodes_;
  std::map<const StateSpec*, int> enter_, complete_;
};

class MachineReader {
 public:
  MachineReader(const BehaviourCatalog& catalog, host::Diagnostics& diag)
      : catalog_(catalog), diag_(diag) {
    for (const auto& name : catalog_.kind_names()) {
      const host::KindInfo* k = catalog_.find(name);
      if (k != nullptr && k->family == host::Family::behaviour) behaviour_kinds_.push_back(name);
    }
  }

  std::unique_ptr<StateSpec> read_root(const host::YamlField& field) {
    if (!field.expect_map()) return nullptr;
    field.check_keys({"name", "initial", "states"});
    auto root = std::make_unique<StateSpec>();
    root->name = field.get_string("name", "tour");
    root->path = root->name;
    root->type = StateType::composite;
    root->mark = field.mark();
    root->field_path = field.path();
    if (!field["states"].defined() || !field["initial"].defined()) {
      field.error("a machine needs initial: and states:");
      return nullptr;
    }
    read_composite_body(field, *root);
    check_composite(field, *root);
    return root;
  }

 private:
  void read_composite_body(const host::YamlField& field, StateSpec& state) {
    if (auto initial = field["initial"].as_string()) state.initial = *initial;
    const host::YamlField states = field["states"];
    if (!states.expect_map()) return;
    for (const auto& kv : states.node()) {
      const std::string name = kv.first.Scalar();
      const host::YamlField child_field = states[name];
      const host::SourceMark name_mark = key_mark(kv.first, states);
      if (++state_count_ > kMaxStates) {
        if (state_count_ == kMaxStates + 1) {
          diag_.error(name_mark, child_field.path(),
                      "more than " + std::to_string(kMaxStates) + " states in one machine");
        }
        return;
      }
      if (is_reserved_target(name) || name.find('/') != std::string::npos || name.empty()) {
        diag_.error(name_mark, child_field.path(),
                    "\"" + name + "\" cannot name a state (reserved word or contains '/')");
        continue;
      }
      auto child = std::make_unique<StateSpec>();
      child->name = name;
      child->path = state.path + "/" + name;
      child->parent = &state;
      child->mark = name_mark;
      child->field_path = child_field.path();
      if (read_state(child_field, *child)) state.children.push_back(std::move(child));
    }
  }

  bool read_state(const host::YamlField& field, StateSpec& state) {
    if (!field.expect_map()) return false;
    const bool is_final = field["final"].defined() && field.get_bool("final", false);
    const bool has_behaviour = field["behaviour"].defined();
    const bool has_states = field["states"].defined() || field["initial"].defined();
    if (is_final + has_behaviour + has_states != 1) {
      field.error(
          "a state needs exactly one of behaviour: (leaf), states: with initial: "
          "(composite) or final: true");
      return false;
    }
    if (is_final) {
      state.type = StateType::final_state;
      field.check_keys({"final"});
      return true;
    }
    if (has_behaviour) {
      state.type = StateType::leaf;
      field.check_keys(
          {"behaviour", "params", "timeout_s", "retries", "on", "projected_on", "description"});
      read_leaf(field, state);
    } else {
      state.type = StateType::composite;
      field.check_keys({"initial", "states", "for_each", "order", "on", "description"});
      if (field["order"].defined()) {
        if (!field["for_each"].defined()) {
          field["order"].error("order: belongs to a for_each: target state");
        } else if (auto order = field["order"].as_enum({"mission", "nearest"})) {
          state.order = *order;
        }
      }
      if (field["for_each"].defined()) {
        if (field["for_each"].as_enum({"target"})) state.for_each_target = true;
        for (const StateSpec* p = state.parent; p != nullptr; p = p->parent) {
          if (p->for_each_target) {
            field["for_each"].error("for_each inside another for_each (" + p->path +
                                    ") is not supported");
          }
        }
      }
      if (!field["initial"].defined() || !field["states"].defined()) {
        field.error("a composite state needs both initial: and states:");
      }
      int depth = 0;
      for (const StateSpec* p = state.parent; p != nullptr; p = p->parent) ++depth;
      if (depth >= kMaxNesting) {
        field.error("composites nested more than " + std::to_string(kMaxNesting) + " deep");
        return false;
      }
      read_composite_body(field, state);
    }
    read_transitions(field["on"], state);
    return true;
  }

  void read_leaf(const host::YamlField& field, StateSpec& state) {
    if (auto kind = field["behaviour"].as_string()) state.behaviour = *kind;
    const host::YamlField timeout = field["timeout_s"];
    if (auto t = timeout.as_double(false)) {
      if (*t < 0) timeout.error("expected a duration >= 0 (0 = no timeout)");
      state.timeout_s = std::max(0.0, *t);
    }
    const host::YamlField retries = field["retries"];
    if (auto r = retries.as_int(false)) {
      if (*r < 0 || *r > kMaxRetries) {
        retries.error("expected a count from 0 to " + std::to_string(kMaxRetries));
      }
      state.retries = static_cast<int>(std::clamp<long long>(*r, 0, kMaxRetries));
    }
    const host::KindInfo* kind = state.behaviour.empty() ? nullptr : catalog_.find(state.behaviour);
    if (!state.behaviour.empty() && (kind == nullptr || kind->family != host::Family::behaviour)) {
      std::string message = "unknown behaviour kind \"" + state.behaviour + "\"";
      if (kind != nullptr) {
        message = "kind \"" + state.behaviour + "\" is a " + to_string(kind->family) +
                  ", not a behaviour";
      } else {
        const std::string suggestion = host::closest_match(state.behaviour, behaviour_kinds_);
        if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
      }
      field["behaviour"].error(message);
      return;
    }
    if (kind == nullptr) return;
    const host::YamlField projected_on = field["projected_on"];
    if (auto outcome = projected_on.as_string(false)) {
      if (!kind->declares_outcome(*outcome)) {
        projected_on.error("behaviour \"" + state.behaviour + "\" does not declare outcome \"" +
                           *outcome + "\" (it declares: " + join(kind->outcomes) + ")");
      } else {
        state.projected_on = *outcome;
      }
    }
    const host::YamlField params = field["params"];
    const std::size_t errors_before = diag_.error_count();
    state.params = host::read_params(kind->params, params);
    if (diag_.error_count() == errors_before) {
      const std::string why = catalog_.validate_params(state.behaviour, state.params);
      if (!why.empty()) params.error(why);
    }
  }

  void read_transitions(const host::YamlField& on, StateSpec& state) {
    if (!on.defined()) return;
    if (state.type == StateType::final_state) {
      on.error("a final state has no transitions");
      return;
    }
    if (!on.expect_map()) return;
    for (const auto& kv : on.node()) {
      TransitionSpec t;
      t.outcome = kv.first.Scalar();
      const host::YamlField value = on[t.outcome];
      t.mark = key_mark(kv.first, on);
      t.field_path = value.path();
      if (value.is_sequence()) {
        t.retry = true;
        for (std::size_t i = 0; i < value.size(); ++i) {
          if (auto s = value[i].as_string()) t.targets.push_back(*s);
        }
        if (value.size() == 0) value.error("expected a state name or a non-empty list");
      } else if (auto s = value.as_string()) {
        t.targets.push_back(*s);
      }
      if (!t.targets.empty()) state.on.push_back(std::move(t));
    }
  }

  // Whole-composite checks, once every child is read (targets may be declared later).
  void check_composite(const host::YamlField& field, const StateSpec& composite) {
    const host::YamlField states = field["states"];
    std::vector<std::string> names;
    for (const auto& c : composite.children) names.push_back(c->name);
    if (!composite.initial.empty() && composite.child(composite.initial) == nullptr) {
      std::string message = "initial state \"" + composite.initial + "\" is not among the states";
      const std::string suggestion = host::closest_match(composite.initial, names);
      if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
      field["initial"].error(message);
    }
    std::vector<std::string> candidates = names;
    for (const char* r : {kSkipTarget, kDeferTarget, kFinish, kAbort}) candidates.push_back(r);
    for (const auto& c : composite.children) {
      const host::YamlField child_field = states[c->name];
      check_transitions(child_field, *c, candidates);
      if (c->is_leaf()) check_leaf_outcomes(child_field, *c);
      if (c->is_composite()) {
        check_composite(child_field, *c);
        if (c->transition(kOutcomeDone) == nullptr) {
          diag_.error(c->mark, c->field_path,
                      "composite state \"" + c->name + "\" has no transition for \"done\"");
        }
        for (const auto& t : c->on) {
          if (t.outcome != kOutcomeDone) {
            diag_.error(t.mark, t.field_path,
                        "a composite state ends only with \"done\", not \"" + t.outcome + "\"");
          }
        }
      }
    }
    check_reachable(composite);
  }

  void check_transitions(const host::YamlField& field, const StateSpec& state,
                         const std::vector<std::string>& candidates) {
    const host::YamlField on = field["on"];
    for (const auto& t : state.on) {
      const host::YamlField value = on[t.outcome];
      for (std::size_t i = 0; i < t.targets.size(); ++i) {
        const std::string& target = t.targets[i];
        const host::YamlField where = value.is_sequence() ? value[i] : value;
        if ((target == kSkipTarget || target == kDeferTarget) &&
            state.parent->enclosing_for_each() == nullptr) {
          where.error(target + " outside a for_each: target state");
        } else if (!is_reserved_target(target) && state.parent->child(target) == nullptr) {
          std::string message = "transition to unknown state \"" + target + "\"";
          const std::string suggestion = host::closest_match(target, candidates);
          if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
          where.error(message);
        }
      }
    }
  }

  void check_leaf_outcomes(const host::YamlField& field, const StateSpec& state) {
    const host::KindInfo* kind = catalog_.find(state.behaviour);
    if (kind == nullptr || kind->family != host::Family::behaviour) return;
    std::vector<std::string> handled_required = kind->outcomes;
    handled_required.push_back(kOutcomeFailed);
    if (state.timeout_s > 0 && !kind_declares_outcome(*kind, kOutcomeTimeout)) {
      handled_required.push_back(kOutcomeTimeout);
    }
    for (const auto& t : state.on) {
      if (std::find(handled_required.begin(), handled_required.end(), t.outcome) ==
          handled_required.end()) {
        std::string message = "behaviour \"" + state.behaviour + "\" does not declare outcome \"" +
                              t.outcome + "\" (it declares: " + join(kind->outcomes) + ")";
        if (t.outcome == kOutcomeTimeout) message += "; set timeout_s to use \"timeout\"";
        if (t.outcome == kOutcomeCancelled) {
          message = "\"cancelled\" is not routed by the machine: a cancel ends the tour";
        }
        diag_.error(t.mark, t.field_path, message);
      }
    }
    for (const auto& outcome : handled_required) {
      if (state.transition(outcome) == nullptr) {
        const host::YamlField on = field["on"];
        const host::YamlField where = on.defined() ? on : field;
        where.error("outcome \"" + outcome + "\" of behaviour \"" + state.behaviour +
                    "\" has no transition");
      }
    }
  }

  void check_reachable(const StateSpec& composite) {
    const StateSpec* initial = composite.child(composite.initial);
    if (initial == nullptr) return;
    std::set<std::string> reached{initial->name};
    std::vector<const StateSpec*> todo{initial};
    while (!todo.empty()) {
      const StateSpec* s = todo.back();
      todo.pop_back();
      for (const auto& t : s->on) {
        for (const auto& target : t.targets) {
          const StateSpec* next = composite.child(target);
          if (next != nullptr && reached.insert(target).second) todo.push_back(next);
        }
      }
    }
    for (const auto& c : composite.children) {
      if (reached.count(c->name) == 0) {
        diag_.error(c->mark, c->field_path,
                    "state \"" + c->name + "\" is unreachable from initial state \"" +
                        composite.initial + "\"");
      }
    }
  }

  const BehaviourCatalog& catalog_;
  host::Diagnostics& diag_;
  std::vector<std::string> behaviour_kinds_;
  std::size_t state_count_ = 0;
};

bool visits_targets(const StateSpec& state) {
  if (state.for_each_target) return true;
  return std::any_of(state.children.begin(), state.children.end(),
                     [](const auto& c) { return visits_targets(*c); });
}

std::optional<Machine> load_checked(const host::YamlField& field, const BehaviourCatalog& catalog,
                                    host::Diagnostics& diag, bool must_visit_targets) {
  const std::size_t errors_before = diag.error_count();
  std::set<std::pair<int, int>> walked;
  check_unique_keys_deep(field.node(), field.path(), field.file(), diag, walked);
  MachineReader reader(catalog, diag);
  auto root = reader.read_root(field);
  if (!root || diag.error_count() != errors_before) return std::nullopt;
  // Judged only on a machine otherwise sound: an unknown target or a missing `done` would
  // show as a dead end here too.
  TerminationCheck(*root, diag).run();
  // Every state is reachable from its composite's initial (checked above), so a for_each
  // anywhere is one the tour enters.
  if (must_visit_targets && !visits_targets(*root)) {
    field["states"].error(
        "no state is a for_each: target state, so the mission's targets would never be "
        "visited");
  }
  if (diag.error_count() != errors_before) return std::nullopt;
  return Machine(std::move(root));
}

}  // namespace

std::optional<Machine> load_machine(const host::YamlField& field, const BehaviourCatalog& catalog,
                                    host::Diagnostics& diag) {
  return load_checked(field, catalog, diag, false);
}

std::optional<Machine> load_machine(const host::MachineSource& source,
                                    const BehaviourCatalog& catalog, host::Diagnostics& diag) {
  if (source.is_default) {
    const auto node = host::load_yaml_string(default_machine_yaml(), kDefaultMachineFile, diag);
    if (!node) return std::nullopt;
    return load_checked(host::YamlField(*node, kDefaultMachineFile, diag), catalog, diag, true);
  }
  if (source.path.empty()) {
    return load_checked(host::YamlField(source.node, source.file, diag), catalog, diag, true);
  }
  // Give the fields their path inside the mission ("machine.states...") by reading the node
  // as a child of a wrapper; the node keeps its own marks.
  YAML::Node wrapper;
  wrapper[source.path] = source.node;
  return load_checked(host::YamlField(wrapper, source.file, diag)[source.path], catalog, diag,
                      true);
}

}  // namespace projtour
