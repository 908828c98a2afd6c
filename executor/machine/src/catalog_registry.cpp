// Kept apart from catalog.cpp so programs using only in-process kinds do not link the loader.
#include "projtour/machine/catalog.hpp"

namespace projtour {

const host::KindInfo* RegistryCatalog::find(const std::string& kind) const {
  return registry_.find(kind);
}

std::vector<std::string> RegistryCatalog::kind_names() const {
  std::vector<std::string> names;
  for (const host::KindInfo* k : registry_.kinds()) names.push_back(k->name);
  return names;
}

std::string RegistryCatalog::validate_params(const std::string& kind, const Params& params) const {
  return registry_.validate_params(kind, params);
}

std::shared_ptr<Behaviour> RegistryCatalog::create_behaviour(const std::string& kind,
                                                             const Params& params,
                                                             const RunContext& run) const {
  return registry_.create_behaviour(kind, params, run);
}

}  // namespace projtour
