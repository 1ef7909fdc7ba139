// Range checks for numeric command-line options, attached where each option is declared, so a
// bad value is refused before any work with a message that names the option and the allowed
// range in words (CLI11 prefixes the option's name).
#pragma once

#include <CLI/CLI.hpp>
#include <cmath>
#include <stdexcept>
#include <string>

namespace kestrel::cli {

/// A finite number in [lo, hi]; `words` says what is allowed ("a duration in (0, 3600] s").
/// Also catches what the option's own type would hide: "-1" for an unsigned count, "nan",
/// "inf", a value too large for the type.
inline CLI::Validator number_in(double lo, double hi, const std::string& words,
                                bool exclusive_lo = false) {
  return CLI::Validator(
      [lo, hi, words, exclusive_lo](std::string& text) -> std::string {
        double v = 0.0;
        try {
          std::size_t used = 0;
          v = std::stod(text, &used);
          if (used != text.size()) throw std::invalid_argument(text);
        } catch (const std::exception&) {
          return "'" + text + "' is not a number; expected " + words;
        }
        const bool low_ok = exclusive_lo ? v > lo : v >= lo;
        if (!std::isfinite(v) || !low_ok || v > hi) return "got " + text + "; expected " + words;
        return {};
      },
      words);
}

}  // namespace kestrel::cli
