#pragma once
#include <filesystem>
#include <string>

namespace projtour {

// Writes `text` to a temporary file beside `file`, flushes and fsyncs it, then renames it over
// `file`, so a reader never sees half a file; never through a symbolic link (write_run_file of
// projtour/contract/run_files.hpp). Throws std::runtime_error naming the file.
void write_file_atomically(const std::filesystem::path& file, const std::string& text);

}  // namespace projtour
