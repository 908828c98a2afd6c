#include "projtour/machine/catalog.hpp"

#include <algorithm>
#include <stdexcept>

namespace projtour {

BehaviourCatalog::~BehaviourCatalog() = default;

bool kind_declares_outcome(const host::KindInfo& kind, const std::string& outcome) {
  return std::find(kind.outcomes.begin(), kind.outcomes.end(), outcome) != kind.outcomes.end();
}

void InProcessCatalog::add(const std::string& kind, std::vector<std::string> outcomes,
                           std::vector<ParamSpec> params, Factory factory, Validator validator,
                           std::vector<host::KeyUse> keys) {
  Entry entry;
  entry.info.name = kind;
  entry.info.family = host::Family::behaviour;
  entry.info.outcomes = std::move(outcomes);
  entry.info.params = std::move(params);
  entry.info.keys = std::move(keys);
  entry.info.plugin_name = "in-process";
  entry.factory = std::move(factory);
  entry.validator = std::move(validator);
  kinds_[kind] = std::move(entry);
}

const host::KindInfo* InProcessCatalog::find(const std::string& kind) const {
  const auto it = kinds_.find(kind);
  return it == kinds_.end() ? nullptr : &it->second.info;
}

std::vector<std::string> InProcessCatalog::kind_names() const {
  std::vector<std::string> names;
  for (const auto& kv : kinds_) names.push_back(kv.first);
  return names;
}

std::string InProcessCatalog::validate_params(const std::string& kind, const Params& params) const {
  const auto it = kinds_.find(kind);
  if (it == kinds_.end() || !it->second.validator) return "";
  return it->second.validator(params);
}

std::shared_ptr<Behaviour> InProcessCatalog::create_behaviour(const std::string& kind,
                                                              const Params& params,
                                                              const RunContext& run) const {
  const auto it = kinds_.find(kind);
  if (it == kinds_.end()) throw std::runtime_error("unknown behaviour kind \"" + kind + "\"");
  return it->second.factory(params, run);
}

}  // namespace projtour
