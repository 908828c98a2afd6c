#pragma once
// Reading what a run leaves in its directory (report.json, checkpoint.json, events.jsonl, the
// sim's *.jsonl logs) with the executor's own strict parser, failing loudly on anything
// truncated or unparsable.
#include <filesystem>
#include <string>
#include <vector>

#include "projtour/formats/json_io.hpp"

namespace projtour::test {

// The file's bytes; throws std::runtime_error naming a file that cannot be read.
std::string read_text(const std::filesystem::path& file);
// The file's bytes, "" when it does not exist (yet).
std::string read_text_if_exists(const std::filesystem::path& file);

// parse_json of a whole file (report.json, checkpoint.json).
Json read_json(const std::filesystem::path& file);

// Every line of a JSON-lines file; throws std::runtime_error naming the file and line when a
// line is not JSON or the file does not end with a newline (a line cut in half).
std::vector<Json> read_jsonl(const std::filesystem::path& file);
// The lines up to the last newline, for a file a running writer may be in the middle of.
std::vector<Json> read_jsonl_complete_lines(const std::filesystem::path& file);

// The three files of a run directory, each read as above.
struct RunFiles {
  Json report;
  Json checkpoint;
  std::vector<Json> events;
};
RunFiles read_run_files(const std::filesystem::path& run_dir);

}  // namespace projtour::test
