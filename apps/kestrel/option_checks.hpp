// Range checks for numeric command-line options, attached where each option is declared, so a
// bad value is refused before any work with a message that names the option and the allowed
// range in words (CLI11 prefixes the option's name).
//
// Every numeric option of `kestrel` carries one of these validators: they are all named
// kRangeCheck, and tests/apps/test_option_ranges.cpp walks the whole command tree to fail on a
// numeric option without one.
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace kestrel::cli {

/// The name of every range validator below (CLI::Option::get_validator finds it by name).
inline constexpr const char* kRangeCheck = "kestrel-range";

/// A finite number in [lo, hi] ((lo, hi] with exclusive_lo); `words` says what is allowed ("a
/// duration in (0, 3600] s"). Also catches what the option's own type would hide: "nan",
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
      words, kRangeCheck);
}

/// A whole number in [lo, hi] written as one ("12", not "1e1" or "12.0", which the integer
/// option would refuse with a message that gives no range); `odd` also requires an odd one.
/// Read as a long long, so a value beyond any integer type is refused, not wrapped: "-1" for
/// an unsigned count, "2000000000" for a count that would run without bound.
inline CLI::Validator whole_in(long long lo, long long hi, const std::string& words,
                               bool odd = false) {
  return CLI::Validator(
      [lo, hi, words, odd](std::string& text) -> std::string {
        long long v = 0;
        const char* first = text.data();
        const char* last = text.data() + text.size();
        if (first != last && *first == '+') ++first;  // from_chars takes no plus sign
        const auto [end, error] = std::from_chars(first, last, v);
        if (text.empty() || end != last) {
          return "'" + text + "' is not a whole number; expected " + words;
        }
        if (error != std::errc() || v < lo || v > hi || (odd && v % 2 == 0)) {
          return "got " + text + "; expected " + words;
        }
        return {};
      },
      words, kRangeCheck);
}

/// A whole number from a short list ("4" or "8"), written as one; read as whole_in reads.
inline CLI::Validator whole_of(std::vector<long long> values, const std::string& words) {
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  const CLI::Validator range = whole_in(*lo, *hi, words);
  return CLI::Validator(
      [range, values, words](std::string& text) -> std::string {
        std::string error = range(text);
        if (!error.empty()) return error;
        if (std::find(values.begin(), values.end(), std::stoll(text)) == values.end()) {
          return "got " + text + "; expected " + words;
        }
        return {};
      },
      words, kRangeCheck);
}

}  // namespace kestrel::cli
