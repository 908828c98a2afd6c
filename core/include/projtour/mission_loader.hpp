#pragma once
// Reading mission, robot and world files. All problems in a file are collected, not only the
// first; relative paths resolve against the file that names them; files named (models, maps,
// content) must exist and be readable.
#include <filesystem>
#include <optional>

#include "projtour/diagnostics.hpp"
#include "projtour/mission.hpp"

namespace projtour {

// nullopt when any error was recorded.
std::optional<MissionSpec> load_mission(const std::filesystem::path& file, Diagnostics& diag);
std::optional<RobotSpec> load_robot(const std::filesystem::path& file, Diagnostics& diag);
std::optional<WorldSpec> load_world(const std::filesystem::path& file, const MissionSpec& mission,
                                    Diagnostics& diag);
// From text (the fuzzer and tests): `file_name` only labels diagnostics and anchors paths.
std::optional<MissionSpec> load_mission_from_string(const std::string& text,
                                                    const std::filesystem::path& file_name,
                                                    Diagnostics& diag);

// Throwing forms: InputError carrying every diagnostic.
MissionSpec load_mission_or_throw(const std::filesystem::path& file);

}  // namespace projtour
