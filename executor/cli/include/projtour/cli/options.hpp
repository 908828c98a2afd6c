#pragma once
// Strict numeric options for the CLI11 parsers of main.cpp and localize_command.cpp. CLI11 2.1
// converts with strtoull/strtod, so on its own it takes "-1" as 2^64-1, saturates
// 18446744073709551616, reads hex ("0x10") and lets "nan" and "inf" through; these parse the
// whole argument with std::from_chars in base 10 and finite range, or fail naming the option.
#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <system_error>

namespace projtour::cli {

template <typename T>
bool parse_whole(const std::string& text, T& out) {
  // from_chars takes a leading '-' for signed and floating types; '+', spaces and, for
  // floating types, "0x" are rejected because parsing stops short of the end.
  const char* const end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && ptr == end && !text.empty();
}

inline CLI::Option* add_uint64(CLI::App& app, const std::string& name,
                               std::function<void(std::uint64_t)> set,
                               const std::string& type_name) {
  return app
      .add_option_function<std::string>(
          name,
          [name, set](const std::string& text) {
            std::uint64_t value = 0;
            if (!parse_whole(text, value)) {
              throw CLI::ValidationError(
                  name, "expects an integer from 0 to 18446744073709551615, got \"" + text + "\"");
            }
            set(value);
          })
      ->type_name(type_name);
}

inline CLI::Option* add_int(CLI::App& app, const std::string& name, std::function<void(int)> set,
                            const std::string& type_name) {
  return app
      .add_option_function<std::string>(name,
                                        [name, set](const std::string& text) {
                                          int value = 0;
                                          if (!parse_whole(text, value)) {
                                            throw CLI::ValidationError(
                                                name, "expects an integer, got \"" + text + "\"");
                                          }
                                          set(value);
                                        })
      ->type_name(type_name);
}

// A finite double; `check` returns an error text for a value out of the option's range.
inline CLI::Option* add_finite(CLI::App& app, const std::string& name,
                               std::function<void(double)> set,
                               std::function<std::string(double)> check,
                               const std::string& type_name) {
  return app
      .add_option_function<std::string>(
          name,
          [name, set, check](const std::string& text) {
            double value = 0.0;
            if (!parse_whole(text, value) || !std::isfinite(value)) {
              throw CLI::ValidationError(name, "expects a finite number, got \"" + text + "\"");
            }
            if (const std::string problem = check ? check(value) : ""; !problem.empty()) {
              throw CLI::ValidationError(name, problem);
            }
            set(value);
          })
      ->type_name(type_name);
}

}  // namespace projtour::cli
