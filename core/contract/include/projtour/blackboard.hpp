#pragma once
// What the steps of a tour tell each other: typed values under string keys.
#include <any>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

namespace projtour {

class Blackboard {
 public:
  template <typename T>
  void set(const std::string& key, T value) {
    values_[key] = std::move(value);
  }
  // nullopt when absent; throws std::logic_error when present with another type.
  template <typename T>
  std::optional<T> get(const std::string& key) const {
    const auto it = values_.find(key);
    if (it == values_.end()) return std::nullopt;
    if (const T* v = std::any_cast<T>(&it->second)) return *v;
    throw std::logic_error("blackboard key \"" + key + "\" holds another type");
  }
  template <typename T>
  T require(const std::string& key) const {
    auto v = get<T>(key);
    if (!v) throw std::runtime_error("blackboard has no \"" + key + "\"");
    return *v;
  }
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  void erase(const std::string& key) { values_.erase(key); }
  // Removes every key starting with `prefix` (per-target state between targets).
  void erase_prefix(const std::string& prefix);

 private:
  std::map<std::string, std::any> values_;
};

}  // namespace projtour
