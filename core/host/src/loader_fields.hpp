#pragma once
// Field readers shared by the mission, robot and world loaders (private to core). Each reads one
// kind of value with the checks every file applies the same way, records what is wrong through
// the field's diagnostics and returns nullopt then, so a loader can keep going and report all.
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/yaml_reader.hpp"

namespace projtour::host::loader {

// Repeated keys are errors: yaml-cpp accepts them silently and the first one wins.
void check_unique_keys(const YamlField& field);
// YamlField::check_keys plus check_unique_keys.
void check_keys(const YamlField& field, const std::vector<std::string>& allowed);

// Shortest text that reads back as the same number ("0.05", "170", "1e-06").
std::string format_number(double value);

enum class Sign { any, positive, non_negative };
std::optional<double> read_number(const YamlField& field, bool required, Sign sign = Sign::any);
std::optional<long long> read_integer(const YamlField& field, bool required, Sign sign = Sign::any);
// Degrees within [-360, 360]: larger values are almost always radians or a typo.
std::optional<double> read_angle_deg(const YamlField& field, bool required);

// A list of exactly N numbers; `shape` names them in the message ("[x, y, z]").
template <std::size_t N>
std::optional<std::array<double, N>> read_numbers(const YamlField& field, bool required,
                                                  const std::string& shape);

// {x, y, z, yaw_deg, roll_deg?, pitch_deg?} -> T_parent_child.
std::optional<Eigen::Isometry3d> read_pose(const YamlField& field, bool required = true);
// {x, y, yaw_deg} on the floor.
std::optional<Pose2D> read_pose2d(const YamlField& field, bool required = true);

// `kind` plus its `params` mapping, left unparsed for the plugin's schema.
std::optional<PluginInstanceSpec> read_plugin_instance(const YamlField& field);

// Lower-cased extension with its dot (".png"), "" when none.
std::string lower_extension(const std::filesystem::path& path);

// Ids name output directories, so they are restricted to a portable character set.
bool is_portable_id(const std::string& id);

extern template std::optional<std::array<double, 2>> read_numbers<2>(const YamlField&, bool,
                                                                     const std::string&);
extern template std::optional<std::array<double, 3>> read_numbers<3>(const YamlField&, bool,
                                                                     const std::string&);
extern template std::optional<std::array<double, 5>> read_numbers<5>(const YamlField&, bool,
                                                                     const std::string&);

}  // namespace projtour::host::loader
