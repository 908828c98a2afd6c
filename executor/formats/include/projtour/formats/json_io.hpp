#pragma once
// The JSON files projtour writes (report.json, checkpoint.json, events.jsonl) and reads back
// (checkpoint.json on --resume, report.json for summary.html), on nlohmann::ordered_json:
// insertion order is kept so every file is written the same way for the same run.
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>

namespace projtour {

using Json = nlohmann::ordered_json;

// The text projtour has always written: ", " and ": " between items on one line (indent < 0),
// doubles in their shortest round-trip form with ".0" kept on whole numbers, non-finite
// doubles as null, strings byte for byte with only '"', '\\' and control characters escaped.
// nlohmann's own dump() differs in all of these (no spaces, Grisu2 digits, fixed notation up to
// 1e15), and the outputs must stay byte-identical across versions.
std::string dump_json(const Json& value, int indent = -1);

// A double as dump_json writes it (for messages that quote a figure of a file).
std::string json_number_text(double value);

// Arrays and objects nested deeper than this are refused: projtour's own files nest five deep,
// and the recursive code that reads and writes a value (from_json, dump_json, the destructor)
// must never meet 50,000 levels (README.md, "The command").
constexpr int kMaxJsonDepth = 64;

// Parses RFC 8259 JSON and nothing more lenient: no trailing characters, comments, leading
// zeros or '+', no invalid escapes, surrogates or UTF-8, no key twice in one object (which
// nlohmann would otherwise resolve silently to the last), and no nesting beyond kMaxJsonDepth.
// Throws std::runtime_error "SOURCE: malformed JSON at byte N: why", N counting from 1.
Json parse_json(const std::string& text, const std::string& source);

// parse_json of the file's contents; a file that cannot be read is a runtime_error naming it.
Json read_json_file(const std::filesystem::path& file);

// Strict field access for from_json: each throws std::runtime_error naming the key when it is
// absent or of another JSON type, rather than nlohmann's silent conversions (a double read as
// int truncates, a negative integer read as uint64 wraps).
namespace json_field {

void expect_object(const Json& value, const char* what);
// Throws naming the first key of `object` that is not in `known`.
void reject_unknown(const Json& object, std::initializer_list<const char*> known);
const Json& required(const Json& object, const char* key);
std::string string_at(const Json& object, const char* key);
// null (a non-finite double as dump_json writes it) reads as NaN.
double number_at(const Json& object, const char* key);
int int_at(const Json& object, const char* key);
std::uint64_t uint64_at(const Json& object, const char* key);

}  // namespace json_field

}  // namespace projtour
