#pragma once
// Typed reading of YAML with every problem collected as a Diagnostic that names the file, the
// line and column, and the field path. Nothing here throws on bad input.
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "projtour/host/diagnostics.hpp"

namespace projtour::host {

// Parses a YAML file; a missing file or a syntax error becomes a diagnostic and a null node.
std::optional<YAML::Node> load_yaml_file(const std::filesystem::path& file, Diagnostics& diag);
std::optional<YAML::Node> load_yaml_string(const std::string& text, const std::string& file_name,
                                           Diagnostics& diag);

// A node together with where it sits: its field path, the file it came from and the nearest
// known mark (yaml-cpp gives a missing key no mark, so the parent's stands in).
class YamlField {
 public:
  YamlField(YAML::Node node, std::string file, Diagnostics& diag);

  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool is_scalar() const { return node_.IsScalar(); }
  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }
  SourceMark mark() const { return mark_; }
  Diagnostics& diagnostics() const { return *diag_; }
  // Joins a child name onto this field's path: "targets[2]" + "pose" -> "targets[2].pose".
  std::string child_path(const std::string& key) const;

  YamlField operator[](const std::string& key) const;
  YamlField operator[](std::size_t index) const;
  std::size_t size() const;
  std::vector<std::string> keys() const;

  // Each returns false (and records why) when the node is of another kind; missing counts as
  // an error only where `required`.
  bool expect_map(bool required = true) const;
  bool expect_sequence(bool required = true) const;
  // Unknown keys are errors, with "did you mean" when one allowed key is close.
  void check_keys(const std::vector<std::string>& allowed) const;
  // Records "missing required field" against this (missing) field.
  void report_missing() const;
  void error(const std::string& message) const;
  void warning(const std::string& message) const;

  // Scalar reads: nullopt (and a diagnostic) when present but of the wrong type; nullopt
  // without a diagnostic when absent and not required.
  std::optional<double> as_double(bool required = true) const;
  std::optional<long long> as_int(bool required = true) const;
  std::optional<bool> as_bool(bool required = true) const;
  std::optional<std::string> as_string(bool required = true) const;
  // A path relative to this field's file; with must_exist, a missing or unreadable file is an
  // error naming both the written and the resolved path.
  std::optional<std::filesystem::path> as_path(bool required = true, bool must_exist = true) const;
  // One of the listed words.
  std::optional<std::string> as_enum(const std::vector<std::string>& allowed,
                                     bool required = true) const;

  // Convenience: child scalar with a default when absent.
  double get_double(const std::string& key, double fallback) const;
  long long get_int(const std::string& key, long long fallback) const;
  bool get_bool(const std::string& key, bool fallback) const;
  std::string get_string(const std::string& key, const std::string& fallback) const;

 private:
  YamlField(YAML::Node node, std::string path, SourceMark mark,
            std::shared_ptr<const std::string> file, Diagnostics* diag);
  std::string describe_value() const;

  YAML::Node node_;
  std::string path_;
  SourceMark mark_;
  std::shared_ptr<const std::string> file_;
  Diagnostics* diag_;
};

}  // namespace projtour::host
