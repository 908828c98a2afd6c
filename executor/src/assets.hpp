#pragma once
// The files of executor/assets/, embedded when the executor is built (executor/CMakeLists.txt,
// cmake/ProjtourEmbed.cmake): each function returns one file's bytes, NUL-terminated, so that
// data() is also a C string.
#include <string_view>

namespace projtour::assets {

// monitor/monitor.html with monitor.css and monitor.js inlined: the live monitor's page.
std::string_view monitor_page();
// summary.css: the summary page's style.
std::string_view summary_css();
// default_machine.yaml: the machine of a mission that says `machine: default`.
std::string_view default_machine();

}  // namespace projtour::assets
