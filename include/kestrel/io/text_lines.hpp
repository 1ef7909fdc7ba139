// Reading line-oriented text files (TUM lists, trajectories, CSVs) with errors that name the
// file and line. Streams: one line in memory at a time.
#pragma once

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/core/time.hpp"

namespace kestrel::io {

class TextLineReader {
 public:
  /// Opens `path`; throws InputError naming it if it cannot be opened.
  explicit TextLineReader(std::filesystem::path path);

  /// Next line that is neither blank nor a comment (first non-space char '#'), with a
  /// trailing carriage return removed. Returns false at end of file.
  bool next(std::string& line);
  [[nodiscard]] std::size_t line_number() const { return line_number_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  /// Throws InputError "FILE:LINE: message" for the current line.
  [[noreturn]] void fail(const std::string& message) const;

 private:
  std::filesystem::path path_;
  std::ifstream in_;
  std::size_t line_number_ = 0;
};

/// Splits on any of `separators` (runs of whitespace count as one separator; commas don't).
std::vector<std::string_view> split_fields(std::string_view line, std::string_view separators);

/// Parses a whole field as a finite double; on failure reader.fail() names field `index`.
double parse_double(std::string_view field, const TextLineReader& reader, std::size_t index);
/// Parses a whole field as an int64 (a nanosecond time stamp); accepts a ".000" fraction of
/// zeros, as in the EuRoC ground-truth CSVs.
long long parse_int64(std::string_view field, const TextLineReader& reader, std::size_t index);

/// Exact decimal-seconds to nanoseconds ("1305031102.175304" -> 1305031102175304000),
/// without going through a double. Returns nullopt if `text` is not a plain decimal number.
std::optional<TimeNs> parse_seconds_to_ns(std::string_view text);

}  // namespace kestrel::io
