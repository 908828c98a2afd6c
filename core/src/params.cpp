#include "projtour/params.hpp"

#include <stdexcept>

namespace projtour {

const char* to_string(ParamType type) {
  switch (type) {
    case ParamType::number:
      return "number";
    case ParamType::integer:
      return "integer";
    case ParamType::boolean:
      return "boolean";
    case ParamType::string:
      return "string";
  }
  return "?";
}

bool param_type_from_string(const std::string& text, ParamType& out) {
  for (ParamType t :
       {ParamType::number, ParamType::integer, ParamType::boolean, ParamType::string}) {
    if (text == to_string(t)) {
      out = t;
      return true;
    }
  }
  return false;
}

const ParamValue& Params::at(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) throw std::out_of_range("no parameter \"" + name + "\"");
  return it->second;
}

double Params::number(const std::string& name) const {
  const ParamValue& v = at(name);
  if (const auto* i = std::get_if<long long>(&v)) return static_cast<double>(*i);
  return std::get<double>(v);
}
long long Params::integer(const std::string& name) const { return std::get<long long>(at(name)); }
bool Params::boolean(const std::string& name) const { return std::get<bool>(at(name)); }
const std::string& Params::string(const std::string& name) const {
  return std::get<std::string>(at(name));
}

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

Params Params::from_yaml(const std::vector<ParamSpec>& schema, const YamlField& field) {
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
      if (auto v = read_value(spec, value)) params.values_[spec.name] = *v;
    } else if (auto d = parse_default(spec)) {
      params.values_[spec.name] = *d;
    } else {
      value.error(std::string("missing required parameter (") + to_string(spec.type) + ")");
    }
  }
  return params;
}

Params Params::defaults(const std::vector<ParamSpec>& schema) {
  Params params;
  for (const auto& spec : schema) {
    auto d = parse_default(spec);
    if (!d) throw std::invalid_argument("parameter \"" + spec.name + "\" has no default");
    params.values_[spec.name] = *d;
  }
  return params;
}

}  // namespace projtour
