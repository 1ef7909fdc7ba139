// Error types for bad input: every message names the file and, where there is one, the line
// or field, so that a user can fix the input without a debugger.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

namespace kestrel {

/// Bad user input (a malformed file, a missing field, an impossible option value).
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
  /// "FILE:LINE: MESSAGE", the compiler-style location a user's editor can jump to.
  InputError(const std::filesystem::path& file, std::size_t line, const std::string& message)
      : std::runtime_error(file.string() + ":" + std::to_string(line) + ": " + message) {}
  /// "FILE: field 'NAME': MESSAGE", for structured files (YAML).
  InputError(const std::filesystem::path& file, const std::string& field,
             const std::string& message)
      : std::runtime_error(file.string() + ": field '" + field + "': " + message) {}
};

}  // namespace kestrel
