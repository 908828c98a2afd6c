#include "projtour/record/target_record.hpp"

#include <stdexcept>
#include <type_traits>
#include <vector>

#include "projtour/record/record_fields.hpp"

namespace projtour {

namespace {

using namespace json_field;

template <class T>
constexpr bool is_optional_v = false;
template <class T>
constexpr bool is_optional_v<std::optional<T>> = true;

// Whether a field of this presence is written, given its value and whether the field before it
// was.
template <class T>
bool written(Presence presence, const T& value, bool previous_written) {
  switch (presence) {
    case Presence::required:
      return true;
    case Presence::optional:
    case Presence::unless_default:
      if constexpr (is_optional_v<T>) {
        return value.has_value();
      } else {
        return !(value == T{});
      }
    case Presence::with_previous:
      return previous_written;
  }
  return true;
}

// Every field of `object`'s type, in their order, as JSON members of `j`.
template <class T>
void write_fields(Json& j, const T& object) {
  j = Json::object();
  bool previous_written = false;
  for_each_field(object, [&](const auto& f, const auto& owner) {
    const auto& value = owner.*f.member;
    previous_written = written(f.presence, value, previous_written);
    if (!previous_written) return;
    if constexpr (is_optional_v<std::decay_t<decltype(value)>>) {
      j[f.key] = *value;
    } else {
      j[f.key] = value;
    }
  });
}

// The value under `key` as a T, by json_field's strict getters; a nested type by its from_json,
// its errors prefixed with the key.
template <class T>
T read_value(const Json& j, const char* key) {
  if constexpr (std::is_same_v<T, std::string>) {
    return string_at(j, key);
  } else if constexpr (std::is_same_v<T, bool>) {
    const Json& v = required(j, key);
    if (!v.is_boolean()) throw std::runtime_error(std::string(key) + ": expected true or false");
    return v.get<bool>();
  } else if constexpr (std::is_same_v<T, int>) {
    return int_at(j, key);
  } else if constexpr (std::is_same_v<T, double>) {
    return number_at(j, key);
  } else {
    static_assert(Fields<T>::kDefined, "a field's type is a JSON value or has Fields<>");
    try {
      return required(j, key).template get<T>();
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(std::string(key) + ": " + e.what());
    }
  }
}

// Reads every field of `object`'s type from `j`, strictly: `j` an object (else "`what` is not
// an object"), no key the type does not define, each field of its JSON type.
template <class T>
void read_fields(const Json& j, T& object, const char* what) {
  expect_object(j, what);
  std::vector<const char*> known;
  for_each_field(object, [&](const auto& f, const auto&) { known.push_back(f.key); });
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool found = false;
    for (const char* k : known) found = found || it.key() == k;
    if (!found) throw std::runtime_error("unknown field \"" + it.key() + "\"");
  }
  bool previous_present = false;
  for_each_field(object, [&](const auto& f, auto& owner) {
    auto& value = owner.*f.member;
    using V = std::decay_t<decltype(value)>;
    const bool present = j.contains(f.key);
    switch (f.presence) {
      case Presence::required:
        value = read_value<field_value_t<V>>(j, f.key);
        break;
      case Presence::optional:
      case Presence::unless_default:
        value = present ? V(read_value<field_value_t<V>>(j, f.key)) : V{};
        break;
      case Presence::with_previous:
        value = previous_present ? read_value<field_value_t<V>>(j, f.key) : V{};
        break;
    }
    previous_present = present;
  });
}

}  // namespace

void to_json(Json& j, const AlignFigures& a) {
  write_fields(j, a);
}
void from_json(const Json& j, AlignFigures& a) {
  read_fields(j, a, "the value");
}
void to_json(Json& j, const LocalizationError& e) {
  write_fields(j, e);
}
void from_json(const Json& j, LocalizationError& e) {
  read_fields(j, e, "the value");
}
void to_json(Json& j, const TargetPoseError& e) {
  write_fields(j, e);
}
void from_json(const Json& j, TargetPoseError& e) {
  read_fields(j, e, "the value");
}
void to_json(Json& j, const BeforeAfter& e) {
  write_fields(j, e);
}
void from_json(const Json& j, BeforeAfter& e) {
  read_fields(j, e, "the value");
}
void to_json(Json& j, const AreaError& e) {
  write_fields(j, e);
}
void from_json(const Json& j, AreaError& e) {
  read_fields(j, e, "the value");
}
void to_json(Json& j, const CalibrateResult& c) {
  write_fields(j, c);
}
void from_json(const Json& j, CalibrateResult& c) {
  read_fields(j, c, "the value");
}
void to_json(Json& j, const TargetRecord& r) {
  write_fields(j, r);
}
void from_json(const Json& j, TargetRecord& r) {
  read_fields(j, r, "a target record");
}

}  // namespace projtour
