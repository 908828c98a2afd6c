#include "projtour/views/monitor_page.hpp"

#include "assets.hpp"

namespace projtour {

// executor/views/assets/monitor/: everything the page shows arrives as JSON and is put in the page
// as text nodes (never as markup), so a target id or an event message cannot inject anything.
// Updates follow the server's stream (at most 2 Hz); the page polls nothing on its own.
const char* monitor_page_html() {
  return assets::monitor_page().data();
}

}  // namespace projtour
