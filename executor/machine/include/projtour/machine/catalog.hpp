#pragma once
// Where the executor finds behaviour kinds: the plugin registry in a run, or kinds registered
// in-process (tests, benchmarks). The machine is checked and its behaviours made through this.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/host/plugin_loader.hpp"

namespace projtour {

class BehaviourCatalog {
 public:
  virtual ~BehaviourCatalog();
  // Any family (so "sim_base used as a behaviour" can be told apart from "unknown").
  virtual const host::KindInfo* find(const std::string& kind) const = 0;
  virtual std::vector<std::string> kind_names() const = 0;
  // "" when fine, else why the values are wrong (the kind's own validate()).
  virtual std::string validate_params(const std::string& kind, const Params& params) const = 0;
  // Throws when the kind is unknown or its create fails.
  virtual std::shared_ptr<Behaviour> create_behaviour(const std::string& kind, const Params& params,
                                                      const RunContext& run) const = 0;
};

bool kind_declares_outcome(const host::KindInfo& kind, const std::string& outcome);

// The plugins a run loaded.
class RegistryCatalog : public BehaviourCatalog {
 public:
  explicit RegistryCatalog(const host::PluginRegistry& registry) : registry_(registry) {}
  const host::KindInfo* find(const std::string& kind) const override;
  std::vector<std::string> kind_names() const override;
  std::string validate_params(const std::string& kind, const Params& params) const override;
  std::shared_ptr<Behaviour> create_behaviour(const std::string& kind, const Params& params,
                                              const RunContext& run) const override;

 private:
  const host::PluginRegistry& registry_;
};

// Behaviour kinds defined in the calling program.
class InProcessCatalog : public BehaviourCatalog {
 public:
  using Factory =
      std::function<std::shared_ptr<Behaviour>(const Params& params, const RunContext& run)>;
  using Validator = std::function<std::string(const Params& params)>;

  void add(const std::string& kind, std::vector<std::string> outcomes,
           std::vector<ParamSpec> params, Factory factory, Validator validator = nullptr,
           std::vector<host::KeyUse> keys = {});

  const host::KindInfo* find(const std::string& kind) const override;
  std::vector<std::string> kind_names() const override;
  std::string validate_params(const std::string& kind, const Params& params) const override;
  std::shared_ptr<Behaviour> create_behaviour(const std::string& kind, const Params& params,
                                              const RunContext& run) const override;

 private:
  struct Entry {
    host::KindInfo info;
    Factory factory;
    Validator validator;
  };
  std::map<std::string, Entry> kinds_;
};

}  // namespace projtour
