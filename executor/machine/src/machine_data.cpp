// The data check of a machine: every key a leaf must read is written before it on every path.
//
// A must-analysis over the leaves: in(L) is what is certainly on the blackboard when L starts,
// the intersection over every way into L of what the state before it left there. Ways into a
// leaf are followed as the executor follows them (a sibling's initial leaf, finish and final
// states completing the composite, a for_each going on to its next target or to its own done,
// skip_target and retry lists used up). A new visit starts with nothing the states wrote.
#include <algorithm>
#include <map>
#include <set>

#include "projtour/machine/machine.hpp"

namespace projtour {

namespace {

using KeySet = std::set<std::string>;

// Where following a transition can lead: a leaf, entered with or without a new visit's clearing.
struct Arrival {
  const StateSpec* leaf;
  bool new_visit;
};

class DataFlow {
 public:
  DataFlow(const Machine& machine, const BehaviourCatalog& catalog)
      : machine_(machine), catalog_(catalog) {}

  // in(L) for every reachable leaf, behaviour-written keys only.
  std::map<const StateSpec*, KeySet> solve() {
    KeySet universe;
    for (const StateSpec* leaf : machine_.leaves()) {
      for (const host::KeyUse& k : keys_of(*leaf)) universe.insert(k.name);
    }
    std::map<const StateSpec*, KeySet> in;
    for (const StateSpec* leaf : machine_.leaves()) in[leaf] = universe;
    std::set<const StateSpec*> reached;
    std::vector<Arrival> entry;
    enter(machine_.root(), false, entry, {});
    for (const Arrival& a : entry) {
      in[a.leaf].clear();
      reached.insert(a.leaf);
    }
    // Each pass only shrinks the sets, so this ends within |leaves| * |keys| passes.
    for (bool changed = true; changed;) {
      changed = false;
      for (const StateSpec* leaf : machine_.leaves()) {
        if (reached.count(leaf) == 0) continue;
        for (const auto& t : leaf->on) {
          const KeySet out = out_of(*leaf, t.outcome, in[leaf]);
          std::vector<Arrival> arrivals;
          follow(*leaf, t, arrivals, {});
          for (const Arrival& a : arrivals) {
            KeySet carried = a.new_visit ? KeySet{} : out;
            KeySet meet;
            const KeySet& before = reached.count(a.leaf) != 0 ? in[a.leaf] : carried;
            std::set_intersection(before.begin(), before.end(), carried.begin(), carried.end(),
                                  std::inserter(meet, meet.begin()));
            if (reached.insert(a.leaf).second || meet != in[a.leaf]) {
              in[a.leaf] = std::move(meet);
              changed = true;
            }
          }
        }
      }
    }
    for (auto it = in.begin(); it != in.end();) {
      it = reached.count(it->first) != 0 ? std::next(it) : in.erase(it);
    }
    return in;
  }

  std::vector<host::KeyUse> keys_of(const StateSpec& leaf) const {
    const host::KindInfo* kind = catalog_.find(leaf.behaviour);
    return kind != nullptr ? kind->keys : std::vector<host::KeyUse>{};
  }

 private:
  // What a leaf leaves behind on `outcome`: its writes count on `succeeded` (on every declared
  // outcome when it declares no `succeeded`), never on failed or timeout.
  KeySet out_of(const StateSpec& leaf, const std::string& outcome, const KeySet& in) const {
    KeySet out = in;
    const host::KindInfo* kind = catalog_.find(leaf.behaviour);
    if (kind == nullptr) return out;
    const bool has_succeeded = kind->declares_outcome("succeeded");
    const bool counts = has_succeeded ? outcome == "succeeded" : kind->declares_outcome(outcome);
    if (!counts) return out;
    for (const host::KeyUse& k : kind->keys) {
      if (k.access == host::KeyAccess::write) out.insert(k.name);
    }
    return out;
  }

  // `seen` guards against composites whose completion leads straight back to themselves.
  void enter(const StateSpec& state, bool new_visit, std::vector<Arrival>& out,
             std::set<const StateSpec*> seen) {
    if (!seen.insert(&state).second) return;
    switch (state.type) {
      case StateType::leaf:
        out.push_back({&state, new_visit});
        return;
      case StateType::final_state:
        complete(*state.parent, new_visit, out, seen);
        return;
      case StateType::composite:
        if (const StateSpec* initial = state.child(state.initial)) {
          enter(*initial, new_visit || state.for_each_target, out, seen);
        }
        // A for_each with no target left completes at once.
        if (state.for_each_target) done(state, new_visit, out, seen);
        return;
    }
  }

  void complete(const StateSpec& composite, bool new_visit, std::vector<Arrival>& out,
                const std::set<const StateSpec*>& seen) {
    if (composite.for_each_target) {
      next_visit(composite, out, seen);
      return;
    }
    done(composite, new_visit, out, seen);
  }

  // The visit ends: the next target's visit, or the for_each's own done.
  void next_visit(const StateSpec& for_each, std::vector<Arrival>& out,
                  const std::set<const StateSpec*>& seen) {
    if (const StateSpec* initial = for_each.child(for_each.initial)) {
      enter(*initial, true, out, seen);
    }
    done(for_each, true, out, seen);
  }

  void done(const StateSpec& composite, bool new_visit, std::vector<Arrival>& out,
            std::set<const StateSpec*> seen) {
    if (composite.parent == nullptr) return;
    if (!seen.insert(&composite).second && !composite.for_each_target) return;
    if (const TransitionSpec* t = composite.transition(kOutcomeDone)) {
      follow_from(composite, *t, new_visit, out, seen);
    }
  }

  void follow(const StateSpec& from, const TransitionSpec& t, std::vector<Arrival>& out,
              const std::set<const StateSpec*>& seen) {
    follow_from(from, t, false, out, seen);
  }

  void follow_from(const StateSpec& from, const TransitionSpec& t, bool new_visit,
                   std::vector<Arrival>& out, const std::set<const StateSpec*>& seen) {
    const StateSpec* for_each =
        from.parent != nullptr ? from.parent->enclosing_for_each() : nullptr;
    std::vector<std::string> targets = t.targets;
    // A retry list used up skips the target (aborts outside a for_each).
    if (t.retry) targets.push_back(for_each != nullptr ? kSkipTarget : kAbort);
    for (const std::string& target : targets) {
      if (target == kAbort) continue;
      if (target == kSkipTarget || target == kDeferTarget) {
        if (for_each != nullptr) next_visit(*for_each, out, seen);
      } else if (target == kFinish) {
        complete(*from.parent, new_visit, out, seen);
      } else if (const StateSpec* sibling = from.parent->child(target)) {
        enter(*sibling, new_visit, out, seen);
      }
    }
  }

  const Machine& machine_;
  const BehaviourCatalog& catalog_;
};

std::string in_quotes(const std::string& s) {
  return "\"" + s + "\"";
}

}  // namespace

void check_machine_data(const Machine& machine, const BehaviourCatalog& catalog,
                        const std::vector<host::KeyUse>& service_writes, host::Diagnostics& diag) {
  DataFlow flow(machine, catalog);
  // One type per key name, over the machine's kinds and the services.
  std::map<std::string, std::pair<std::string, std::string>> type_of;  // name -> (type, who)
  const auto agree = [&](const host::KeyUse& k, const std::string& who, const StateSpec* at) {
    const auto [it, inserted] = type_of.emplace(k.name, std::make_pair(k.type, who));
    if (inserted || it->second.first == k.type) return;
    const std::string message = "key " + in_quotes(k.name) + " is a " + in_quotes(k.type) + " to " +
                                who + " but a " + in_quotes(it->second.first) + " to " +
                                it->second.second;
    if (at != nullptr) {
      diag.error(at->mark, at->field_path + ".behaviour", message);
    } else {
      diag.error(host::SourceMark{}, "", message);
    }
  };
  KeySet from_services;
  for (const host::KeyUse& k : service_writes) {
    agree(k, "a service", nullptr);
    from_services.insert(k.name);
  }
  std::map<std::string, std::vector<std::string>> writers;  // key -> leaf paths
  for (const StateSpec* leaf : machine.leaves()) {
    for (const host::KeyUse& k : flow.keys_of(*leaf)) {
      agree(k, "behaviour " + in_quotes(leaf->behaviour) + " (" + leaf->path + ")", leaf);
      if (k.access == host::KeyAccess::write) writers[k.name].push_back(leaf->path);
    }
  }
  for (const auto& [leaf, in] : flow.solve()) {
    for (const host::KeyUse& k : flow.keys_of(*leaf)) {
      if (k.access != host::KeyAccess::read || in.count(k.name) || from_services.count(k.name))
        continue;
      std::string message = "behaviour " + in_quotes(leaf->behaviour) + " reads " +
                            in_quotes(k.name) + " (" + k.type + "), which ";
      const auto w = writers.find(k.name);
      if (w == writers.end()) {
        message += "no state of the machine and no service writes";
      } else {
        std::string names;
        for (const auto& p : w->second) names += (names.empty() ? "" : ", ") + p;
        message += "is not written on every path that reaches it (written by " + names + ")";
      }
      diag.error(leaf->mark, leaf->field_path + ".behaviour", message);
    }
  }
}

}  // namespace projtour
