#pragma once
// summary.html: one self-contained page per run (inline CSS, no network) with the report's
// figures, tour.png and each target's pictures, linked by paths relative to the run directory.
#include <filesystem>

#include "projtour/formats/json_io.hpp"

namespace projtour {

struct SummaryInput {
  Json report;  // report.json as build_report() makes it (run/report.hpp); missing fields show "-"
};

// Reads run_dir/report.json, parsed strictly (json_io.hpp). Throws std::runtime_error naming
// the file when it is unreadable or malformed.
SummaryInput read_summary_input(const std::filesystem::path& run_dir);

// The page as text. Pictures are looked up under run_dir and only those on disk are shown. Each
// <img> marks itself data-loaded="1" once decoded ("0" on error), so a headless browser can
// check the page.
std::string render_summary_page(const SummaryInput& input, const std::filesystem::path& run_dir);

// Writes run_dir/summary.html atomically. Throws std::runtime_error naming the file.
void write_summary_page(const SummaryInput& input, const std::filesystem::path& run_dir);

}  // namespace projtour
