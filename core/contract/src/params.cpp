#include "projtour/contract/params.hpp"

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
long long Params::integer(const std::string& name) const {
  return std::get<long long>(at(name));
}
bool Params::boolean(const std::string& name) const {
  return std::get<bool>(at(name));
}
const std::string& Params::string(const std::string& name) const {
  return std::get<std::string>(at(name));
}

}  // namespace projtour
