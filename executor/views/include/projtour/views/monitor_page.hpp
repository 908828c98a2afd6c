#pragma once
// The live monitor's page (GET /): one self-contained HTML document, inline CSS and script, no
// external resources, so that it works on a robot with no network beyond the operator's laptop.
// It draws from the monitor's JSON API (monitor.hpp) and takes its token from the URL fragment
// (#token=...), which the browser never sends to the server, or from a field on the page.
// Kept as files, executor/views/assets/monitor/ (HTML, CSS, script), put together into this one
// document when the executor is built.

namespace projtour {

const char* monitor_page_html();

}  // namespace projtour
