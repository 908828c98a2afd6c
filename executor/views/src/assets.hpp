#pragma once
// The pages' files embedded when the views are built (executor/views/CMakeLists.txt,
// cmake/ProjtourEmbed.cmake): each function returns one file's bytes, NUL-terminated, so that
// data() is also a C string.
#include <string_view>

namespace projtour::assets {

// assets/monitor/monitor.html with monitor.css and monitor.js inlined: the live monitor's page.
std::string_view monitor_page();
// assets/summary.css: the summary page's style.
std::string_view summary_css();

}  // namespace projtour::assets
