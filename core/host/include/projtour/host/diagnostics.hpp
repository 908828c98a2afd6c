#pragma once
// Problems found in input files, each with where it is and what was expected.
#include <stdexcept>
#include <string>
#include <vector>

namespace projtour::host {

// 1-based line and column; 0 means unknown (the file as a whole).
struct SourceMark {
  std::string file;
  int line = 0;
  int column = 0;
};

enum class Severity { error, warning };

struct Diagnostic {
  Severity severity = Severity::error;
  SourceMark mark;
  std::string field_path;  // "targets[2].pose.yaw_deg", empty for the file as a whole
  std::string message;     // "expected a number, got \"north\""

  // "FILE:LINE:COL: targets[2].pose.yaw_deg: expected a number, got "north""
  // (warnings carry "warning: " before the field path)
  std::string format() const;
};

class Diagnostics {
 public:
  void error(const SourceMark& mark, std::string field_path, std::string message);
  void warning(const SourceMark& mark, std::string field_path, std::string message);
  void add(Diagnostic d) { items_.push_back(std::move(d)); }
  void append(const Diagnostics& other);

  bool has_errors() const;
  std::size_t error_count() const;
  const std::vector<Diagnostic>& items() const { return items_; }
  // One diagnostic per line.
  std::string format() const;

 private:
  std::vector<Diagnostic> items_;
};

// Thrown when input is invalid; what() holds every problem, one per line.
class InputError : public std::runtime_error {
 public:
  explicit InputError(Diagnostics diagnostics);
  const Diagnostics& diagnostics() const { return diagnostics_; }

 private:
  Diagnostics diagnostics_;
};

// Closest candidate within a small edit distance, or "" (for "did you mean").
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace projtour::host
