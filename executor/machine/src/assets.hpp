#pragma once
// The machine's file embedded when it is built (executor/machine/CMakeLists.txt,
// cmake/ProjtourEmbed.cmake): the bytes of default_machine.yaml, NUL-terminated.
#include <string_view>

namespace projtour::assets {

// default_machine.yaml: the machine of a mission that says `machine: default`.
std::string_view default_machine();

}  // namespace projtour::assets
