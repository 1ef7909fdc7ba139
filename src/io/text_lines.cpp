// Line reader and strict number parsing for Kestrel's text formats.
#include "kestrel/io/text_lines.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

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

}  // namespace kestrel::io
