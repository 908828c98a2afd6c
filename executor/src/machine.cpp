#include "projtour_executor/machine.hpp"

#include <algorithm>
#include <functional>
#include <set>

#include "projtour/params_reader.hpp"

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

SourceMark key_mark(const YAML::Node& key, const YamlField& parent) {
  const YAML::Mark m = key.Mark();
  if (m.is_null() || m.line < 0) return parent.mark();
  return SourceMark{parent.file(), m.line + 1, m.column + 1};
}

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

class MachineReader {
 public:
  MachineReader(const BehaviourCatalog& catalog, Diagnostics& diag)
      : catalog_(catalog), diag_(diag) {
    for (const auto& name : catalog_.kind_names()) {
      const KindInfo* k = catalog_.find(name);
      if (k != nullptr && k->family == Family::behaviour) behaviour_kinds_.push_back(name);
    }
  }

  std::unique_ptr<StateSpec> read_root(const YamlField& field) {
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
  void read_composite_body(const YamlField& field, StateSpec& state) {
    if (auto initial = field["initial"].as_string()) state.initial = *initial;
    const YamlField states = field["states"];
    if (!states.expect_map()) return;
    for (const auto& kv : states.node()) {
      const std::string name = kv.first.Scalar();
      const YamlField child_field = states[name];
      const SourceMark name_mark = key_mark(kv.first, states);
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

  bool read_state(const YamlField& field, StateSpec& state) {
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
      read_composite_body(field, state);
    }
    read_transitions(field["on"], state);
    return true;
  }

  void read_leaf(const YamlField& field, StateSpec& state) {
    if (auto kind = field["behaviour"].as_string()) state.behaviour = *kind;
    const YamlField timeout = field["timeout_s"];
    if (auto t = timeout.as_double(false)) {
      if (*t < 0) timeout.error("expected a duration >= 0 (0 = no timeout)");
      state.timeout_s = std::max(0.0, *t);
    }
    const YamlField retries = field["retries"];
    if (auto r = retries.as_int(false)) {
      if (*r < 0) retries.error("expected a count >= 0");
      state.retries = static_cast<int>(std::max(0LL, *r));
    }
    const KindInfo* kind = state.behaviour.empty() ? nullptr : catalog_.find(state.behaviour);
    if (!state.behaviour.empty() && (kind == nullptr || kind->family != Family::behaviour)) {
      std::string message = "unknown behaviour kind \"" + state.behaviour + "\"";
      if (kind != nullptr) {
        message = "kind \"" + state.behaviour + "\" is a " + to_string(kind->family) +
                  ", not a behaviour";
      } else {
        const std::string suggestion = closest_match(state.behaviour, behaviour_kinds_);
        if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
      }
      field["behaviour"].error(message);
      return;
    }
    if (kind == nullptr) return;
    const YamlField projected_on = field["projected_on"];
    if (auto outcome = projected_on.as_string(false)) {
      if (!kind->declares_outcome(*outcome)) {
        projected_on.error("behaviour \"" + state.behaviour + "\" does not declare outcome \"" +
                           *outcome + "\" (it declares: " + join(kind->outcomes) + ")");
      } else {
        state.projected_on = *outcome;
      }
    }
    const YamlField params = field["params"];
    const std::size_t errors_before = diag_.error_count();
    state.params = read_params(kind->params, params);
    if (diag_.error_count() == errors_before) {
      const std::string why = catalog_.validate_params(state.behaviour, state.params);
      if (!why.empty()) params.error(why);
    }
  }

  void read_transitions(const YamlField& on, StateSpec& state) {
    if (!on.defined()) return;
    if (state.type == StateType::final_state) {
      on.error("a final state has no transitions");
      return;
    }
    if (!on.expect_map()) return;
    for (const auto& kv : on.node()) {
      TransitionSpec t;
      t.outcome = kv.first.Scalar();
      const YamlField value = on[t.outcome];
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
  void check_composite(const YamlField& field, const StateSpec& composite) {
    const YamlField states = field["states"];
    std::vector<std::string> names;
    for (const auto& c : composite.children) names.push_back(c->name);
    if (!composite.initial.empty() && composite.child(composite.initial) == nullptr) {
      std::string message = "initial state \"" + composite.initial + "\" is not among the states";
      const std::string suggestion = closest_match(composite.initial, names);
      if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
      field["initial"].error(message);
    }
    std::vector<std::string> candidates = names;
    for (const char* r : {kSkipTarget, kDeferTarget, kFinish, kAbort}) candidates.push_back(r);
    for (const auto& c : composite.children) {
      const YamlField child_field = states[c->name];
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

  void check_transitions(const YamlField& field, const StateSpec& state,
                         const std::vector<std::string>& candidates) {
    const YamlField on = field["on"];
    for (const auto& t : state.on) {
      const YamlField value = on[t.outcome];
      for (std::size_t i = 0; i < t.targets.size(); ++i) {
        const std::string& target = t.targets[i];
        const YamlField where = value.is_sequence() ? value[i] : value;
        if ((target == kSkipTarget || target == kDeferTarget) &&
            state.parent->enclosing_for_each() == nullptr) {
          where.error(target + " outside a for_each: target state");
        } else if (!is_reserved_target(target) && state.parent->child(target) == nullptr) {
          std::string message = "transition to unknown state \"" + target + "\"";
          const std::string suggestion = closest_match(target, candidates);
          if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
          where.error(message);
        }
      }
    }
  }

  void check_leaf_outcomes(const YamlField& field, const StateSpec& state) {
    const KindInfo* kind = catalog_.find(state.behaviour);
    if (kind == nullptr || kind->family != Family::behaviour) return;
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
        const YamlField on = field["on"];
        const YamlField where = on.defined() ? on : field;
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
  Diagnostics& diag_;
  std::vector<std::string> behaviour_kinds_;
};

}  // namespace

std::optional<Machine> load_machine(const YamlField& field, const BehaviourCatalog& catalog,
                                    Diagnostics& diag) {
  const std::size_t errors_before = diag.error_count();
  MachineReader reader(catalog, diag);
  auto root = reader.read_root(field);
  if (!root || diag.error_count() != errors_before) return std::nullopt;
  return Machine(std::move(root));
}

std::optional<Machine> load_machine(const MachineSource& source, const BehaviourCatalog& catalog,
                                    Diagnostics& diag) {
  if (source.is_default) {
    const auto node = load_yaml_string(default_machine_yaml(), kDefaultMachineFile, diag);
    if (!node) return std::nullopt;
    return load_machine(YamlField(*node, kDefaultMachineFile, diag), catalog, diag);
  }
  if (source.path.empty())
    return load_machine(YamlField(source.node, source.file, diag), catalog, diag);
  // Give the fields their path inside the mission ("machine.states...") by reading the node
  // as a child of a wrapper; the node keeps its own marks.
  YAML::Node wrapper;
  wrapper[source.path] = source.node;
  return load_machine(YamlField(wrapper, source.file, diag)[source.path], catalog, diag);
}

}  // namespace projtour
