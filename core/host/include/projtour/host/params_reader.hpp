#pragma once
// Parameter values from YAML, checked against a kind's schema. The contract's Params holds
// values only, so a plugin never links the YAML reader.
#include <vector>

#include "projtour/contract/params.hpp"
#include "projtour/host/yaml_reader.hpp"

namespace projtour::host {

// Reads `field` (a mapping, or absent) against `schema`: unknown names, wrong types and
// missing required values become diagnostics; defaults fill the rest.
Params read_params(const std::vector<ParamSpec>& schema, const YamlField& field);
// Defaults only (throws std::invalid_argument if a required parameter has none).
Params default_params(const std::vector<ParamSpec>& schema);

}  // namespace projtour::host
