#include "projtour/formats/json_io.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <stdexcept>
#include <vector>

namespace projtour {

namespace {

void escape_to(std::string& out, const std::string& s) {
  out += '"';
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  out += '"';
}

void newline(std::string& out, int indent, int depth) {
  if (indent < 0) return;
  out += '\n';
  out.append(static_cast<std::size_t>(indent * depth), ' ');
}

void dump_to(std::string& out, const Json& j, int indent, int depth) {
  switch (j.type()) {
    case Json::value_t::null:
    case Json::value_t::discarded:
      out += "null";
      return;
    case Json::value_t::boolean:
      out += j.get<bool>() ? "true" : "false";
      return;
    case Json::value_t::number_integer:
      out += std::to_string(j.get<std::int64_t>());
      return;
    case Json::value_t::number_unsigned:
      out += std::to_string(j.get<std::uint64_t>());
      return;
    case Json::value_t::number_float:
      out += json_number_text(j.get<double>());
      return;
    case Json::value_t::string:
      escape_to(out, j.get_ref<const std::string&>());
      return;
    case Json::value_t::array: {
      out += '[';
      bool first = true;
      for (const Json& item : j) {
        if (!first) out += indent < 0 ? ", " : ",";
        first = false;
        newline(out, indent, depth + 1);
        dump_to(out, item, indent, depth + 1);
      }
      if (!j.empty()) newline(out, indent, depth);
      out += ']';
      return;
    }
    case Json::value_t::object: {
      out += '{';
      bool first = true;
      for (auto it = j.begin(); it != j.end(); ++it) {
        if (!first) out += indent < 0 ? ", " : ",";
        first = false;
        newline(out, indent, depth + 1);
        escape_to(out, it.key());
        out += ": ";
        dump_to(out, it.value(), indent, depth + 1);
      }
      if (!j.empty()) newline(out, indent, depth);
      out += '}';
      return;
    }
    case Json::value_t::binary:
      break;
  }
  throw std::logic_error("dump_json: binary values have no JSON text");
}

// Feeds the parser and remembers how far it has read, so an error the parser callback raises
// (a duplicate key) can name its byte offset as nlohmann's own parse errors do.
class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, const char** furthest) : p_(p), furthest_(furthest) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    *furthest_ = ++p_;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator before = *this;
    ++*this;
    return before;
  }
  bool operator==(const CountingIterator& other) const { return p_ == other.p_; }
  bool operator!=(const CountingIterator& other) const { return p_ != other.p_; }

 private:
  const char* p_;
  const char** furthest_;
};

struct DuplicateKey {
  std::string key;
  std::size_t byte;
};
struct TooDeep {
  std::size_t byte;
};

[[noreturn]] void malformed(const std::string& source, std::size_t byte, const std::string& why) {
  throw std::runtime_error(source + ": malformed JSON at byte " + std::to_string(byte) + ": " +
                           why);
}

[[noreturn]] void field_error(const char* key, const std::string& what) {
  throw std::runtime_error(std::string("\"") + key + "\" " + what);
}

}  // namespace

std::string dump_json(const Json& value, int indent) {
  std::string out;
  dump_to(out, value, indent, 0);
  return out;
}

std::string json_number_text(double value) {
  if (!std::isfinite(value)) return "null";  // JSON has no inf/nan
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, value);
  std::string text(buf, res.ptr);
  // Keeps doubles recognisable as such when read back.
  if (text.find_first_of(".eE") == std::string::npos) text += ".0";
  return text;
}

Json parse_json(const std::string& text, const std::string& source) {
  const char* const begin = text.data();
  const char* furthest = begin;
  std::vector<std::set<std::string>> open_objects;
  const Json::parser_callback_t on_event = [&](int depth, Json::parse_event_t event, Json& parsed) {
    // `depth` counts the arrays and objects around the one starting.
    if ((event == Json::parse_event_t::object_start || event == Json::parse_event_t::array_start) &&
        depth >= kMaxJsonDepth) {
      throw TooDeep{static_cast<std::size_t>(furthest - begin)};
    }
    switch (event) {
      case Json::parse_event_t::object_start:
        open_objects.emplace_back();
        break;
      case Json::parse_event_t::object_end:
        open_objects.pop_back();
        break;
      case Json::parse_event_t::key: {
        const std::string& key = parsed.get_ref<const std::string&>();
        if (!open_objects.back().insert(key).second) {
          throw DuplicateKey{key, static_cast<std::size_t>(furthest - begin)};
        }
        break;
      }
      default:
        break;
    }
    return true;
  };
  try {
    return Json::parse(CountingIterator(begin, &furthest),
                       CountingIterator(begin + text.size(), &furthest), on_event);
  } catch (const DuplicateKey& d) {
    malformed(source, d.byte, "duplicate key \"" + d.key + "\"");
  } catch (const TooDeep& d) {
    malformed(source, d.byte,
              "nested deeper than " + std::to_string(kMaxJsonDepth) + " arrays and objects");
  } catch (const Json::out_of_range&) {
    // A number beyond a double ("-1e600"): nlohmann throws this, not a parse_error (fuzzer).
    malformed(source, static_cast<std::size_t>(furthest - begin), "number out of range");
  } catch (const Json::parse_error& e) {
    // "[json.exception.parse_error.101] parse error at line 1, column 3: ..." without the tag.
    std::string why = e.what();
    if (const auto tag_end = why.find("] ");
        why.rfind("[json.exception.", 0) == 0 && tag_end != std::string::npos) {
      why.erase(0, tag_end + 2);
    }
    malformed(source, e.byte, why);
  }
}

Json read_json_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot read");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw std::runtime_error(file.string() + ": cannot read");
  return parse_json(text, file.string());
}

namespace json_field {

void expect_object(const Json& value, const char* what) {
  if (!value.is_object()) {
    throw std::runtime_error(std::string(what) + " is not an object but " + value.type_name());
  }
}

void reject_unknown(const Json& object, std::initializer_list<const char*> known) {
  for (auto it = object.begin(); it != object.end(); ++it) {
    bool found = false;
    for (const char* k : known) found = found || it.key() == k;
    if (!found) throw std::runtime_error("unknown field \"" + it.key() + "\"");
  }
}

const Json& required(const Json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) field_error(key, "is missing");
  return *it;
}

std::string string_at(const Json& object, const char* key) {
  const Json& v = required(object, key);
  if (!v.is_string()) field_error(key, std::string("is not a string but ") + v.type_name());
  return v.get<std::string>();
}

double number_at(const Json& object, const char* key) {
  const Json& v = required(object, key);
  // dump_json writes a NaN or infinite figure as null; reading it back as NaN lets a checkpoint
  // holding one resume, and writes the same null again.
  if (v.is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!v.is_number()) field_error(key, std::string("is not a number but ") + v.type_name());
  return v.get<double>();
}

int int_at(const Json& object, const char* key) {
  const Json& v = required(object, key);
  if (!v.is_number_integer()) field_error(key, "is not an integer");
  const std::int64_t i = v.get<std::int64_t>();
  if (v.is_number_unsigned() && v.get<std::uint64_t>() > std::numeric_limits<int>::max()) {
    field_error(key, "is out of range");
  }
  if (i < std::numeric_limits<int>::min() || i > std::numeric_limits<int>::max()) {
    field_error(key, "is out of range");
  }
  return static_cast<int>(i);
}

std::uint64_t uint64_at(const Json& object, const char* key) {
  const Json& v = required(object, key);
  // nlohmann reads every integer without a '-' as unsigned.
  if (!v.is_number_unsigned()) field_error(key, "is not an unsigned integer");
  return v.get<std::uint64_t>();
}

}  // namespace json_field

}  // namespace projtour
