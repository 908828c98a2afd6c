#pragma once
#include <string>

namespace projtour {

enum class LogLevel { debug, info, warning, error };

class Logger {
 public:
  virtual ~Logger();
  virtual void log(LogLevel level, const std::string& message) = 0;
  void debug(const std::string& m) { log(LogLevel::debug, m); }
  void info(const std::string& m) { log(LogLevel::info, m); }
  void warning(const std::string& m) { log(LogLevel::warning, m); }
  void error(const std::string& m) { log(LogLevel::error, m); }
};

// Writes warnings and errors to stderr.
class StderrLogger : public Logger {
 public:
  explicit StderrLogger(LogLevel threshold = LogLevel::warning) : threshold_(threshold) {}
  void log(LogLevel level, const std::string& message) override;

 private:
  LogLevel threshold_;
};

}  // namespace projtour
