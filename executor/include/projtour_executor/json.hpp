#pragma once
// A small JSON value for the executor's outputs (report, checkpoint, events). Objects keep
// their insertion order so every file is written the same way for the same run.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace projtour {

class Json {
 public:
  using Array = std::vector<Json>;
  using Object = std::vector<std::pair<std::string, Json>>;

  Json() = default;  // null
  Json(std::nullptr_t) {}
  Json(bool b) : value_(b) {}
  Json(int i) : value_(static_cast<long long>(i)) {}
  Json(long i) : value_(static_cast<long long>(i)) {}
  Json(long long i) : value_(i) {}
  Json(unsigned long long i) : value_(static_cast<long long>(i)) {}
  Json(std::size_t i) : value_(static_cast<long long>(i)) {}
  Json(double d) : value_(d) {}
  Json(const char* s) : value_(std::string(s)) {}
  Json(std::string s) : value_(std::move(s)) {}
  Json(Array a) : value_(std::move(a)) {}
  Json(Object o) : value_(std::move(o)) {}

  static Json object() { return Json(Object{}); }
  static Json array() { return Json(Array{}); }

  bool is_null() const { return std::holds_alternative<std::nullptr_t>(value_); }
  bool is_bool() const { return std::holds_alternative<bool>(value_); }
  bool is_number() const {
    return std::holds_alternative<double>(value_) || std::holds_alternative<long long>(value_);
  }
  bool is_string() const { return std::holds_alternative<std::string>(value_); }
  bool is_array() const { return std::holds_alternative<Array>(value_); }
  bool is_object() const { return std::holds_alternative<Object>(value_); }

  // Each throws std::runtime_error when the value is of another type.
  bool as_bool() const;
  double as_double() const;
  long long as_int() const;
  const std::string& as_string() const;
  const Array& as_array() const;
  Array& as_array();
  const Object& as_object() const;

  // Objects: replaces the value under `key` or appends it.
  Json& set(const std::string& key, Json value);
  // nullptr when absent (or not an object).
  const Json* find(const std::string& key) const;
  // Throws std::runtime_error naming the key when absent.
  const Json& at(const std::string& key) const;
  void push_back(Json value);

  // indent < 0: one line. Doubles are written in their shortest round-trip form.
  std::string dump(int indent = -1) const;
  // Throws std::runtime_error with the offset on malformed text.
  static Json parse(const std::string& text);

 private:
  void dump_to(std::string& out, int indent, int depth) const;
  std::variant<std::nullptr_t, bool, long long, double, std::string, Array, Object> value_;
};

// Writes `text` to a temporary file beside `file`, flushes and fsyncs it, then renames it over
// `file`, so a reader never sees half a file. Throws std::runtime_error naming the file.
void write_file_atomically(const std::filesystem::path& file, const std::string& text);

}  // namespace projtour
