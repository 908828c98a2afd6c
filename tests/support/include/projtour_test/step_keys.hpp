#pragma once
// Checks a step's use of the blackboard against the keys its descriptor declares, by running the
// step's real code: while it runs, every key that some loaded kind declares but this step does
// not is held under a value of a type no step uses (Poison). The blackboard refuses a read or a
// write of a key holding another type (BlackboardTypeError, naming the key), so a step that
// reads or writes a key it does not declare throws on the spot, whichever path of its code does
// it. The keys come from the descriptors of every plugin built (`plugin_dir`), not from a list
// kept here.
//
// What it cannot see: `Blackboard::has` checks no type, and a key no loaded kind declares is not
// poisoned. Keys a service running beside the step uses are left alone (`running_beside`): the
// service's own test checks them.
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "projtour/contract/blackboard.hpp"
#include "projtour/host/plugin_loader.hpp"

namespace projtour::test {

struct Poison {};

class StepKeys {
 public:
  // `step` is the kind under test; `running_beside`, kinds (services) that run with it.
  StepKeys(const std::filesystem::path& plugin_dir, const std::string& step,
           const std::vector<std::string>& running_beside = {}) {
    host::PluginRegistry registry;
    registry.load_directories({plugin_dir});
    declared_ = registry.require(step).keys;
    std::set<std::string> spared;
    for (const host::KeyUse& use : declared_) spared.insert(use.name);
    for (const std::string& kind : running_beside) {
      for (const host::KeyUse& use : registry.require(kind).keys) spared.insert(use.name);
    }
    for (const host::KindInfo* kind : registry.kinds()) {
      for (const host::KeyUse& use : kind->keys) {
        if (spared.count(use.name) == 0) poisoned_.insert(use.name);
      }
    }
  }

  // Puts a Poison under every key the step does not declare (whatever was there goes).
  void poison(Blackboard& board) const {
    for (const std::string& name : poisoned_) {
      const Key<Poison> key{name.c_str(), KeyScope::tour, "key the step does not declare"};
      board.erase(key);
      board.set(key, Poison{});
    }
  }

  // The declared writes the step made since `writes_before` (Blackboard::writes()).
  std::set<std::string> written_since(const Blackboard& board, std::uint64_t writes_before) const {
    std::set<std::string> written;
    for (const host::KeyUse& use : declared_) {
      const Key<Poison> key{use.name.c_str(), KeyScope::visit, ""};
      if (use.access == host::KeyAccess::write && board.version(key) > writes_before) {
        written.insert(use.name);
      }
    }
    return written;
  }
  std::set<std::string> declared_writes() const {
    std::set<std::string> out;
    for (const host::KeyUse& use : declared_) {
      if (use.access == host::KeyAccess::write) out.insert(use.name);
    }
    return out;
  }
  const std::set<std::string>& poisoned() const { return poisoned_; }

 private:
  std::vector<host::KeyUse> declared_;
  std::set<std::string> poisoned_;
};

}  // namespace projtour::test
