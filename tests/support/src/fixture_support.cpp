#include "projtour_test/fixture_support.hpp"

#include "projtour/host/params_reader.hpp"
#include "projtour/host/yaml_reader.hpp"

namespace projtour::testing {

std::filesystem::path fixture(const std::string& name) {
  return std::filesystem::path(PROJTOUR_FIXTURE_DIR) / ("lib" + name + ".so");
}

Params params_from_yaml(const std::vector<ParamSpec>& schema, const std::string& yaml,
                        host::Diagnostics& diag) {
  const auto node = host::load_yaml_string(yaml, "params.yaml", diag);
  if (!node) return Params();
  return host::read_params(schema, host::YamlField(*node, "params.yaml", diag));
}

}  // namespace projtour::testing
