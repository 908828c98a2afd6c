#pragma once
// What the steps of a tour tell each other: one typed value per key. A Key<T> names the slot and
// fixes its type, so a reader and a writer that use the same constant cannot disagree about it;
// two constants that share a name but not a type are refused at the first write or read.
#include <any>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <typeinfo>
#include <utility>

namespace projtour {

// visit: cleared when the visit of a new target starts (a step's result for this target).
// tour: kept for the whole run (the localization service's estimate).
enum class KeyScope { visit, tour };

template <typename T>
struct Key {
  const char* name;  // "align", "localization.estimate"
  KeyScope scope;
  const char* type;  // T's name as descriptors and `projtour plugins` show it
};

// The wrong type under a key: a programming error in a plugin, never bad input.
class BlackboardTypeError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

class Blackboard {
 public:
  // Stores `value` under `key` (moved, never copied again). Throws BlackboardTypeError when the
  // key holds a value of another type.
  template <typename T>
  void set(const Key<T>& key, T value) {
    Entry& entry = entries_[key.name];
    if (entry.value.has_value() && entry.value.type() != typeid(T)) throw type_error(key, entry);
    entry.value = std::move(value);
    entry.scope = key.scope;
    entry.type = key.type;
    entry.version = ++writes_;
  }
  // The value under `key`, or null when there is none. The pointer is valid until the key is
  // written or erased. Throws BlackboardTypeError when the key holds another type.
  template <typename T>
  const T* find(const Key<T>& key) const {
    const auto it = entries_.find(key.name);
    if (it == entries_.end()) return nullptr;
    if (const T* value = std::any_cast<T>(&it->second.value)) return value;
    throw type_error(key, it->second);
  }
  template <typename T>
  bool has(const Key<T>& key) const {
    return entries_.count(key.name) != 0;
  }
  template <typename T>
  void erase(const Key<T>& key) {
    entries_.erase(key.name);
  }
  // Erases every visit-scoped key (a new target's visit begins).
  void clear_visit();

  // Counts every write. A key's version is the count at its last write, so a reader can tell
  // whether a value was written after a given moment (the executor measures what a state wrote).
  std::uint64_t writes() const { return writes_; }
  template <typename T>
  std::uint64_t version(const Key<T>& key) const {
    const auto it = entries_.find(key.name);
    return it == entries_.end() ? 0 : it->second.version;
  }

 private:
  struct Entry {
    std::any value;
    KeyScope scope = KeyScope::visit;
    const char* type = "";
    std::uint64_t version = 0;
  };
  template <typename T>
  static BlackboardTypeError type_error(const Key<T>& key, const Entry& entry) {
    return BlackboardTypeError(std::string("blackboard key \"") + key.name + "\" holds a " +
                               entry.type + ", not a " + key.type);
  }

  std::map<std::string, Entry, std::less<>> entries_;
  std::uint64_t writes_ = 0;
};

}  // namespace projtour
