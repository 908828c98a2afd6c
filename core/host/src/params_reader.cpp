#include "projtour/host/params_reader.hpp"

#include <stdexcept>

namespace projtour::host {

namespace {

std::optional<ParamValue> read_value(const ParamSpec& spec, const YamlField& field) {
  switch (spec.type) {
    case ParamType::number:
      if (auto v = field.as_double()) return ParamValue(*v);
      break;
    case ParamType::integer:
      if (auto v = field.as_int()) return ParamValue(*v);
      break;
    case ParamType::boolean:
      if (auto v = field.as_bool()) return ParamValue(*v);
      break;
    case ParamType::string:
      if (auto v = field.as_string()) return ParamValue(*v);
      break;
  }
  return std::nullopt;
}

std::optional<ParamValue> parse_default(const ParamSpec& spec) {
  if (spec.type == ParamType::string) return ParamValue(spec.default_value);
  if (spec.default_value.empty()) return std::nullopt;
  Diagnostics scratch;
  const auto node = load_yaml_string(spec.default_value, "<default>", scratch);
  if (!node) return std::nullopt;
  return read_value(spec, YamlField(*node, "<default>", scratch));
}

}  // namespace

Params read_params(const std::vector<ParamSpec>& schema, const YamlField& field) {
  Params params;
  std::vector<std::string> names;
  for (const auto& spec : schema) names.push_back(spec.name);
  if (field.defined()) {
    if (!field.expect_map()) return params;
    field.check_keys(names);
  }
  for (const auto& spec : schema) {
    const YamlField value = field[spec.name];
    if (value.defined()) {
      if (auto v = read_value(spec, value)) params.set(spec.name, *v);
    } else if (auto d = parse_default(spec)) {
      params.set(spec.name, *d);
    } else {
      value.error(std::string("missing required parameter (") + to_string(spec.type) + ")");
    }
  }
  return params;
}

Params default_params(const std::vector<ParamSpec>& schema) {
  Params params;
  for (const auto& spec : schema) {
    auto d = parse_default(spec);
    if (!d) throw std::invalid_argument("parameter \"" + spec.name + "\" has no default");
    params.set(spec.name, *d);
  }
  return params;
}

}  // namespace projtour::host
