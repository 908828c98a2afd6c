#include "projtour_test/run_files.hpp"

#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace projtour::test {

namespace fs = std::filesystem;

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string read_text_if_exists(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

Json read_json(const fs::path& file) {
  return read_json_file(file);
}

namespace {

std::vector<Json> parse_lines(const std::string& text, const fs::path& file) {
  std::vector<Json> out;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    try {
      out.push_back(parse_json(line, file.string()));
    } catch (const std::exception& e) {
      throw std::runtime_error(file.string() + ":" + std::to_string(number) + ": " + e.what() +
                               ": " + line);
    }
  }
  return out;
}

}  // namespace

std::vector<Json> read_jsonl(const fs::path& file) {
  const std::string text = read_text(file);
  if (!text.empty() && text.back() != '\n') {
    throw std::runtime_error(file.string() + ": the last line is cut (no newline at the end)");
  }
  return parse_lines(text, file);
}

std::vector<Json> read_jsonl_complete_lines(const fs::path& file) {
  std::string text = read_text(file);
  const auto last_newline = text.rfind('\n');
  text.erase(last_newline == std::string::npos ? 0 : last_newline + 1);
  return parse_lines(text, file);
}

RunFiles read_run_files(const fs::path& run_dir) {
  RunFiles files;
  files.report = read_json(run_dir / "report.json");
  files.checkpoint = read_json(run_dir / "checkpoint.json");
  files.events = read_jsonl(run_dir / "events.jsonl");
  return files;
}

}  // namespace projtour::test
