#include "projtour_test/chromium.hpp"

#include <unistd.h>

#include <regex>
#include <stdexcept>

#include "projtour_test/process.hpp"

namespace projtour::test {

std::string chromium_command() {
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (::access(candidate, X_OK) == 0) return candidate;
  }
  return "";
}

std::string dom_in_chromium(const std::filesystem::path& html,
                            const std::filesystem::path& scratch) {
  const std::filesystem::path profile = scratch / "chromium-profile";
  std::filesystem::create_directories(profile);
  ChildOptions chromium;
  chromium.argv = {chromium_command(),
                   "--headless",
                   "--no-sandbox",
                   "--disable-gpu",
                   "--disable-quic",
                   "--no-first-run",
                   "--disable-background-networking",
                   "--disable-component-update",
                   "--disable-sync",
                   "--user-data-dir=" + profile.string(),
                   "--virtual-time-budget=5000",
                   "--dump-dom",
                   "file://" + std::filesystem::absolute(html).string()};
  const RunResult r = run(chromium, std::chrono::seconds(60));
  std::filesystem::remove_all(profile);
  if (r.status != 0) throw std::runtime_error("chromium failed (" + std::to_string(r.status) + ")");
  return r.out;
}

std::vector<LoadedImage> images_of(const std::string& dom) {
  std::vector<LoadedImage> images;
  const std::regex img(R"(<img\b[^>]*>)");
  const std::regex src(R"re(\bsrc="([^"]*)")re");
  const std::regex loaded(R"re(\bdata-loaded="([^"]*)")re");
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), img); it != std::sregex_iterator();
       ++it) {
    const std::string tag = it->str();
    std::smatch m;
    LoadedImage image;
    if (std::regex_search(tag, m, src)) image.src = m[1];
    if (std::regex_search(tag, m, loaded)) image.loaded = m[1];
    images.push_back(image);
  }
  return images;
}

}  // namespace projtour::test
