#include "loader_fields.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>

namespace projtour::host::loader {

void check_unique_keys(const YamlField& field) {
  if (!field.is_map()) return;
  std::map<std::string, int> first_line;
  for (const auto& kv : field.node()) {
    if (!kv.first.IsScalar()) continue;
    const std::string& key = kv.first.Scalar();
    const YAML::Mark m = kv.first.Mark();
    const auto [it, inserted] = first_line.emplace(key, m.line + 1);
    if (inserted) continue;
    field.diagnostics().error(
        SourceMark{field.file(), m.line + 1, m.column + 1}, field.child_path(key),
        "duplicate key \"" + key + "\" (first at line " + std::to_string(it->second) + ")");
  }
}

void check_keys(const YamlField& field, const std::vector<std::string>& allowed) {
  field.check_keys(allowed);
  check_unique_keys(field);
}

std::string format_number(double value) {
  char buffer[32];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

namespace {

// The number as written ("1e3" stays "1e3"), so the message quotes the file.
std::string written(const YamlField& field) {
  return field.is_scalar() ? field.node().Scalar() : std::string();
}

bool sign_ok(double value, Sign sign) {
  switch (sign) {
    case Sign::positive:
      return value > 0.0;
    case Sign::non_negative:
      return value >= 0.0;
    case Sign::any:
      break;
  }
  return true;
}

const char* sign_bound(Sign sign) {
  return sign == Sign::positive ? "> 0" : ">= 0";
}

}  // namespace

std::optional<double> read_number(const YamlField& field, bool required, Sign sign) {
  const auto value = field.as_double(required);
  if (!value) return std::nullopt;
  if (!sign_ok(*value, sign)) {
    field.error(std::string("expected a number ") + sign_bound(sign) + ", got " + written(field));
    return std::nullopt;
  }
  return value;
}

std::optional<long long> read_integer(const YamlField& field, bool required, Sign sign) {
  const auto value = field.as_int(required);
  if (!value) return std::nullopt;
  if (!sign_ok(static_cast<double>(*value), sign)) {
    field.error(std::string("expected an integer ") + sign_bound(sign) + ", got " + written(field));
    return std::nullopt;
  }
  return value;
}

std::optional<double> read_angle_deg(const YamlField& field, bool required) {
  const auto value = field.as_double(required);
  if (!value) return std::nullopt;
  if (*value < -360.0 || *value > 360.0) {
    field.error("expected an angle in degrees within [-360, 360], got " + written(field));
    return std::nullopt;
  }
  return value;
}

template <std::size_t N>
std::optional<std::array<double, N>> read_numbers(const YamlField& field, bool required,
                                                  const std::string& shape) {
  if (!field.expect_sequence(required)) return std::nullopt;
  bool ok = true;
  if (field.size() != N) {
    field.error("expected " + std::to_string(N) + " numbers " + shape + ", got " +
                std::to_string(field.size()));
    ok = false;
  }
  std::array<double, N> out{};
  // Every element is read, even after a count mismatch, so a wrong type is reported too.
  for (std::size_t i = 0; i < field.size(); ++i) {
    const auto value = field[i].as_double();
    if (!value) {
      ok = false;
    } else if (i < N) {
      out[i] = *value;
    }
  }
  if (!ok) return std::nullopt;
  return out;
}

template std::optional<std::array<double, 2>> read_numbers<2>(const YamlField&, bool,
                                                              const std::string&);
template std::optional<std::array<double, 3>> read_numbers<3>(const YamlField&, bool,
                                                              const std::string&);
template std::optional<std::array<double, 5>> read_numbers<5>(const YamlField&, bool,
                                                              const std::string&);

std::optional<Eigen::Isometry3d> read_pose(const YamlField& field, bool required) {
  if (!field.expect_map(required)) return std::nullopt;
  check_keys(field, {"x", "y", "z", "yaw_deg", "roll_deg", "pitch_deg"});
  const auto x = read_number(field["x"], true);
  const auto y = read_number(field["y"], true);
  const auto z = read_number(field["z"], true);
  const auto yaw = read_angle_deg(field["yaw_deg"], true);
  const auto roll = read_angle_deg(field["roll_deg"], false);
  const auto pitch = read_angle_deg(field["pitch_deg"], false);
  const bool roll_ok = roll || !field["roll_deg"].defined();
  const bool pitch_ok = pitch || !field["pitch_deg"].defined();
  if (!x || !y || !z || !yaw || !roll_ok || !pitch_ok) return std::nullopt;
  return isometry_from_xyz_rpy(*x, *y, *z, deg_to_rad(roll.value_or(0.0)),
                               deg_to_rad(pitch.value_or(0.0)), deg_to_rad(*yaw));
}

std::optional<Pose2D> read_pose2d(const YamlField& field, bool required) {
  if (!field.expect_map(required)) return std::nullopt;
  check_keys(field, {"x", "y", "yaw_deg"});
  const auto x = read_number(field["x"], true);
  const auto y = read_number(field["y"], true);
  const auto yaw = read_angle_deg(field["yaw_deg"], true);
  if (!x || !y || !yaw) return std::nullopt;
  return Pose2D{*x, *y, deg_to_rad(*yaw)};
}

std::optional<PluginInstanceSpec> read_plugin_instance(const YamlField& field) {
  if (!field.expect_map(true)) return std::nullopt;
  check_keys(field, {"kind", "params"});
  const YamlField kind = field["kind"];
  const YamlField params = field["params"];
  auto kind_text = kind.as_string(true);
  if (kind_text && kind_text->empty()) {
    kind.error("expected a plugin kind name, got an empty string");
    kind_text.reset();
  }
  const bool params_ok = params.expect_map(false) || !params.defined();
  if (!kind_text || !params_ok) return std::nullopt;
  PluginInstanceSpec spec;
  spec.kind = *kind_text;
  // Absent params stay Undefined (a default Node is Null, which would read as "params: ~").
  spec.params = params.defined() ? params.node() : YAML::Node(YAML::NodeType::Undefined);
  spec.params_path = params.path();
  spec.mark = params.mark();
  return spec;
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

bool is_portable_id(const std::string& id) {
  return !id.empty() && std::all_of(id.begin(), id.end(), [](unsigned char c) {
    // Spelt out rather than std::isalnum, whose answer depends on the locale.
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

}  // namespace projtour::host::loader
