// Shared by the fuzz targets: most of Kestrel's parsers read a file by path (as the CLI gives
// them), so each input is written to one file in a private temporary folder and the parser is
// called on that path. The folder is empty apart from the input, so a relative path named in
// the input (a config naming another file) resolves to nothing rather than to a real file.
//
// A parser may refuse an input only with the errors Kestrel reports to users: InputError (file,
// line and field named) or std::invalid_argument (an option's validate()). Any other exception
// escapes the target and libFuzzer reports it as a finding, like a crash: a YAML::Exception or
// std::out_of_range reaching the user says "bad conversion" or "stoi" and names nothing.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "kestrel/core/error.hpp"

namespace kestrel::fuzz {

class InputFile {
 public:
  /// `name` is the file's name in the folder (its extension matters to some loaders).
  explicit InputFile(const std::string& name) {
    const auto dir =
        std::filesystem::temp_directory_path() / ("kestrel-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    path_ = dir / name;
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  ~InputFile() {
    std::error_code ignored;
    std::filesystem::remove_all(path_.parent_path(), ignored);
  }

  /// Replaces the file's content with the fuzzer's bytes; returns its path.
  const std::filesystem::path& write(const std::uint8_t* data, std::size_t size) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) throw std::runtime_error("fuzz: cannot write " + path_.string());
    return path_;
  }

 private:
  std::filesystem::path path_;
};

/// Calls `parse()`, accepting the refusals a user may see (see above).
template <typename Parse>
void expect_parsed_or_refused(Parse&& parse) {
  try {
    parse();
  } catch (const InputError&) {
  } catch (const std::invalid_argument&) {
  }
}

}  // namespace kestrel::fuzz
