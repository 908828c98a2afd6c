#include "projtour/host/yaml_reader.hpp"

#include <cmath>
#include <fstream>

namespace projtour::host {

namespace {

SourceMark mark_of(const YAML::Node& node, const std::string& file, const SourceMark& fallback) {
  if (!node.IsDefined()) return fallback;
  const YAML::Mark m = node.Mark();
  if (m.is_null() || m.line < 0) return fallback;
  return SourceMark{file, m.line + 1, m.column + 1};
}

std::optional<YAML::Node> parse(const std::string& text, const std::string& file,
                                Diagnostics& diag) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    diag.error(SourceMark{file, e.mark.line + 1, e.mark.column + 1}, "",
               "YAML syntax error: " + e.msg);
  }
  return std::nullopt;
}

}  // namespace

std::optional<YAML::Node> load_yaml_file(const std::filesystem::path& file, Diagnostics& diag) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    diag.error(SourceMark{file.string(), 0, 0}, "", "cannot open file");
    return std::nullopt;
  }
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse(text, file.string(), diag);
}

std::optional<YAML::Node> load_yaml_string(const std::string& text, const std::string& file_name,
                                           Diagnostics& diag) {
  return parse(text, file_name, diag);
}

YamlField::YamlField(YAML::Node node, std::string file, Diagnostics& diag)
    : node_(std::move(node)),
      file_(std::make_shared<const std::string>(std::move(file))),
      diag_(&diag) {
  mark_ = mark_of(node_, *file_, SourceMark{*file_, 1, 1});
}

YamlField::YamlField(YAML::Node node, std::string path, SourceMark mark,
                     std::shared_ptr<const std::string> file, Diagnostics* diag)
    : node_(std::move(node)),
      path_(std::move(path)),
      mark_(std::move(mark)),
      file_(std::move(file)),
      diag_(diag) {}

std::string YamlField::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

YamlField YamlField::operator[](const std::string& key) const {
  // yaml-cpp returns an invalid "zombie" node for a missing key, on which most calls throw;
  // a fresh undefined node stands in for it.
  YAML::Node child(YAML::NodeType::Undefined);
  if (node_.IsMap()) {
    const YAML::Node& self = node_;
    const YAML::Node found = self[key];
    if (found.IsDefined()) child.reset(found);
  }
  return YamlField(child, child_path(key), mark_of(child, *file_, mark_), file_, diag_);
}

YamlField YamlField::operator[](std::size_t index) const {
  YAML::Node child(YAML::NodeType::Undefined);
  if (node_.IsSequence() && index < node_.size()) {
    const YAML::Node& self = node_;
    const YAML::Node found = self[index];
    if (found.IsDefined()) child.reset(found);
  }
  return YamlField(child, path_ + "[" + std::to_string(index) + "]", mark_of(child, *file_, mark_),
                   file_, diag_);
}

std::size_t YamlField::size() const {
  return (node_.IsSequence() || node_.IsMap()) ? node_.size() : 0;
}

std::vector<std::string> YamlField::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) {
    out.push_back(kv.first.IsScalar() ? kv.first.Scalar() : std::string("<non-scalar key>"));
  }
  return out;
}

std::string YamlField::describe_value() const {
  if (!node_.IsDefined()) return "nothing";
  switch (node_.Type()) {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Scalar:
      return "\"" + node_.Scalar() + "\"";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    default:
      return "nothing";
  }
}

void YamlField::error(const std::string& message) const {
  diag_->error(mark_, path_, message);
}
void YamlField::warning(const std::string& message) const {
  diag_->warning(mark_, path_, message);
}
void YamlField::report_missing() const {
  error("missing required field");
}

bool YamlField::expect_map(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return false;
  }
  if (!node_.IsMap()) {
    error("expected a mapping, got " + describe_value());
    return false;
  }
  return true;
}

bool YamlField::expect_sequence(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return false;
  }
  if (!node_.IsSequence()) {
    error("expected a list, got " + describe_value());
    return false;
  }
  return true;
}

void YamlField::check_keys(const std::vector<std::string>& allowed) const {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "<non-scalar key>";
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string message = "unknown key \"" + key + "\"";
    const std::string suggestion = closest_match(key, allowed);
    if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
    diag_->error(mark_of(kv.first, *file_, mark_), child_path(key), message);
  }
}

std::optional<double> YamlField::as_double(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return std::nullopt;
  }
  if (node_.IsScalar()) {
    const std::string& s = node_.Scalar();
    try {
      std::size_t used = 0;
      const double v = std::stod(s, &used);
      if (used == s.size() && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
  }
  error("expected a number, got " + describe_value());
  return std::nullopt;
}

std::optional<long long> YamlField::as_int(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return std::nullopt;
  }
  if (node_.IsScalar()) {
    const std::string& s = node_.Scalar();
    try {
      std::size_t used = 0;
      const long long v = std::stoll(s, &used);
      if (used == s.size()) return v;
    } catch (const std::exception&) {
    }
  }
  error("expected an integer, got " + describe_value());
  return std::nullopt;
}

std::optional<bool> YamlField::as_bool(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return std::nullopt;
  }
  if (node_.IsScalar()) {
    const std::string& s = node_.Scalar();
    if (s == "true" || s == "True" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "False" || s == "no" || s == "off") return false;
  }
  error("expected true or false, got " + describe_value());
  return std::nullopt;
}

std::optional<std::string> YamlField::as_string(bool required) const {
  if (!defined()) {
    if (required) report_missing();
    return std::nullopt;
  }
  if (node_.IsScalar()) return node_.Scalar();
  error("expected a string, got " + describe_value());
  return std::nullopt;
}

std::optional<std::filesystem::path> YamlField::as_path(bool required, bool must_exist) const {
  const auto text = as_string(required);
  if (!text) return std::nullopt;
  if (text->empty()) {
    error("expected a file path, got an empty string");
    return std::nullopt;
  }
  std::filesystem::path p(*text);
  if (p.is_relative()) p = std::filesystem::path(*file_).parent_path() / p;
  p = p.lexically_normal();
  if (must_exist) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) {
      error("file \"" + *text + "\" not found (looked at " + p.string() + ")");
      return std::nullopt;
    }
    std::ifstream probe(p, std::ios::binary);
    if (!probe) {
      error("file \"" + *text + "\" is not readable (" + p.string() + ")");
      return std::nullopt;
    }
  }
  return p;
}

std::optional<std::string> YamlField::as_enum(const std::vector<std::string>& allowed,
                                              bool required) const {
  const auto text = as_string(required);
  if (!text) return std::nullopt;
  if (std::find(allowed.begin(), allowed.end(), *text) != allowed.end()) return text;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  std::string message = "expected one of " + list + ", got \"" + *text + "\"";
  const std::string suggestion = closest_match(*text, allowed);
  if (!suggestion.empty()) message += "; did you mean \"" + suggestion + "\"?";
  error(message);
  return std::nullopt;
}

double YamlField::get_double(const std::string& key, double fallback) const {
  return (*this)[key].as_double(false).value_or(fallback);
}
long long YamlField::get_int(const std::string& key, long long fallback) const {
  return (*this)[key].as_int(false).value_or(fallback);
}
bool YamlField::get_bool(const std::string& key, bool fallback) const {
  return (*this)[key].as_bool(false).value_or(fallback);
}
std::string YamlField::get_string(const std::string& key, const std::string& fallback) const {
  return (*this)[key].as_string(false).value_or(fallback);
}

}  // namespace projtour::host
