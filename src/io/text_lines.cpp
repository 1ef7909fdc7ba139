// Line reader and strict number parsing for Kestrel's text formats.
#include "kestrel/io/text_lines.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include "kestrel/core/error.hpp"

namespace kestrel::io {

TextLineReader::TextLineReader(std::filesystem::path path) : path_(std::move(path)) {
  if (std::filesystem::is_directory(path_)) {
    throw InputError(path_.string() + ": is a directory, expected a text file");
  }
  in_.open(path_);
  if (!in_) throw InputError(path_.string() + ": cannot open file for reading");
}

bool TextLineReader::next(std::string& line) {
  while (std::getline(in_, line)) {
    ++line_number_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    return true;
  }
  if (in_.bad()) fail("read error");
  return false;
}

void TextLineReader::fail(const std::string& message) const {
  throw InputError(path_, line_number_, message);
}

std::vector<std::string_view> split_fields(std::string_view line, std::string_view separators) {
  std::vector<std::string_view> out;
  const bool commas = separators.find(',') != std::string_view::npos;
  std::size_t i = 0;
  while (i <= line.size()) {
    // Skip leading whitespace of the field.
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) {
      if (commas && !out.empty() && line.find_last_not_of(" \t") != std::string_view::npos &&
          line[line.find_last_not_of(" \t")] == ',') {
        out.emplace_back();  // trailing empty field after a comma
      }
      break;
    }
    std::size_t j = i;
    while (j < line.size() && separators.find(line[j]) == std::string_view::npos) ++j;
    std::size_t end = j;
    while (end > i && (line[end - 1] == ' ' || line[end - 1] == '\t')) --end;
    out.push_back(line.substr(i, end - i));
    if (j >= line.size()) break;
    // Consume the separator (a comma, or a run of whitespace).
    i = j + 1;
  }
  return out;
}

double parse_double(std::string_view field, const TextLineReader& reader, std::size_t index) {
  double value = 0.0;
  const auto* begin = field.data();
  const auto* end = field.data() + field.size();
  if (!field.empty() && *begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (field.empty() || ec != std::errc() || ptr != end || !std::isfinite(value)) {
    reader.fail("field " + std::to_string(index + 1) + " is not a finite number: '" +
                std::string(field) + "'");
  }
  return value;
}

long long parse_int64(std::string_view field, const TextLineReader& reader, std::size_t index) {
  long long value = 0;
  const auto* end = field.data() + field.size();
  const auto [ptr, ec] = std::from_chars(field.data(), end, value);
  bool ok = !field.empty() && ec == std::errc();
  if (ok && ptr != end) {
    // Allow "123.000": a fractional part of zeros only.
    ok = *ptr == '.' && std::all_of(ptr + 1, end, [](char c) { return c == '0'; });
  }
  if (!ok) {
    reader.fail("field " + std::to_string(index + 1) + " is not an integer time stamp: '" +
                std::string(field) + "'");
  }
  return value;
}

std::optional<TimeNs> parse_seconds_to_ns(std::string_view text) {
  if (text.empty()) return std::nullopt;
  bool negative = false;
  if (text.front() == '-' || text.front() == '+') {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const auto dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  std::string_view frac = dot == std::string_view::npos ? std::string_view() : text.substr(dot + 1);
  if (whole.empty() && frac.empty()) return std::nullopt;
  const auto digits = [](std::string_view s) {
    return std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!digits(whole) || !digits(frac)) return std::nullopt;
  // Beyond this many seconds the nanosecond count would not fit a TimeNs (year 2262).
  constexpr TimeNs kMaxSeconds = std::numeric_limits<TimeNs>::max() / 1'000'000'000 - 1;
  TimeNs seconds = 0;
  for (char c : whole) {
    seconds = seconds * 10 + (c - '0');
    if (seconds > kMaxSeconds) return std::nullopt;
  }
  TimeNs nanos = 0;
  int places = 0;
  for (char c : frac) {
    if (places == 9) {
      if (c >= '5') ++nanos;  // round on the 10th decimal, ignore the rest
      break;
    }
    nanos = nanos * 10 + (c - '0');
    ++places;
  }
  for (; places < 9; ++places) nanos *= 10;
  const TimeNs t = seconds * 1'000'000'000 + nanos;
  return negative ? -t : t;
}

}  // namespace kestrel::io
