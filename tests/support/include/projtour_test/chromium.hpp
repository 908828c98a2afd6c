#pragma once
// Pages checked in a real browser: headless Chromium loads a file and hands back its final DOM,
// where each <img> marked by its onload/onerror (data-loaded="1" or "0") says whether it loaded.
#include <filesystem>
#include <string>
#include <vector>

namespace projtour::test {

// The installed Chromium, or "" (a test skips then).
std::string chromium_command();

// The page's DOM after 5 s of virtual time; throws when Chromium fails. Its profile lives under
// `scratch` for the call.
std::string dom_in_chromium(const std::filesystem::path& html,
                            const std::filesystem::path& scratch);

struct LoadedImage {
  std::string src;
  std::string loaded;  // "1", "0", or "" when the browser never reported
};
// Every <img> of a DOM in order.
std::vector<LoadedImage> images_of(const std::string& dom);

}  // namespace projtour::test
