#pragma once
// Typed parameters of a plugin kind: the schema a kind declares and the values a mission gives
// (read from YAML by the host: params_reader.hpp).
#include <map>
#include <string>
#include <variant>
#include <vector>

namespace projtour {

enum class ParamType { number, integer, boolean, string };
const char* to_string(ParamType type);
// "number" | "integer" | "boolean" | "string"; false when unknown.
bool param_type_from_string(const std::string& text, ParamType& out);

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::number;
  std::string default_value;  // as written in YAML; empty string = required
  std::string description;
  bool required() const { return default_value.empty() && type != ParamType::string; }
};

using ParamValue = std::variant<double, long long, bool, std::string>;

// Parameter values, complete (defaults filled in) and checked against a schema.
class Params {
 public:
  Params() = default;

  double number(const std::string& name) const;
  long long integer(const std::string& name) const;
  bool boolean(const std::string& name) const;
  const std::string& string(const std::string& name) const;
  bool has(const std::string& name) const { return values_.count(name) != 0; }

  void set(const std::string& name, ParamValue value) { values_[name] = std::move(value); }
  const std::map<std::string, ParamValue>& values() const { return values_; }

 private:
  const ParamValue& at(const std::string& name) const;
  std::map<std::string, ParamValue> values_;
};

}  // namespace projtour
