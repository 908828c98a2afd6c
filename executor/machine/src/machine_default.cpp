// The default tour, executor/machine/default_machine.yaml, written in the same YAML a mission may
// use to replace it. Its diagnostics name it kDefaultMachineFile, with the file's lines.
#include "assets.hpp"
#include "projtour/machine/machine.hpp"

namespace projtour {

const std::string& default_machine_yaml() {
  static const std::string kText(assets::default_machine());
  return kText;
}

}  // namespace projtour
