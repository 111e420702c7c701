// Checks of numeric command-line values whose refusals say what is expected ("--threads:
// expected a number >= 0, got -1"): CLI11's PositiveNumber and NonNegativeNumber print their
// range up to the largest double, 300 digits.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <string>

namespace fascia::app {

// A finite number > 0 (strictly) or >= 0; the option's own type then converts it (an integer
// option refuses 1.5 itself).
inline CLI::Validator number_check(bool strictly) {
  const std::string expected = strictly ? "a number > 0" : "a number >= 0";
  return CLI::Validator(
      [strictly, expected](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        const bool number = !text.empty() && end && *end == '\0' && std::isfinite(value);
        if (number && (strictly ? value > 0 : value >= 0)) return {};
        return "expected " + expected + ", got " + text;
      },
      strictly ? "POSITIVE" : "NONNEGATIVE");
}

inline const CLI::Validator kPositiveNumber = number_check(true);
inline const CLI::Validator kNonNegativeNumber = number_check(false);

}  // namespace fascia::app
