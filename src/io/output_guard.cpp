// Provenance checks before Kestrel writes a file or folder.
#include "kestrel/io/output_guard.hpp"

#include <fstream>

#include "kestrel/core/error.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

namespace {
constexpr const char* kMarker = ".kestrel-output";

std::string first_line(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}
}  // namespace

std::string provenance_line(std::string_view command) {
  return "# written by kestrel " + std::string(command);
}

void check_can_write_file(const fs::path& path, std::string_view command, bool force) {
  if (fs::is_directory(path)) {
    throw InputError(path.string() + ": is a directory; expected a file name to write");
  }
  if (fs::exists(path) && !force) {
    const std::string line = first_line(path);
    if (line != provenance_line(command)) {
      const std::string by = line.rfind("# written by kestrel ", 0) == 0
                                 ? "it was written by `kestrel " + line.substr(21) + "`"
                                 : "it was not written by Kestrel";
      throw InputError(path.string() + ": refusing to overwrite: " + by +
                       " (pass --force to overwrite it)");
    }
  }
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
}

void claim_output_dir(const fs::path& dir, std::string_view command, bool force) {
  if (fs::exists(dir) && !fs::is_directory(dir)) {
    throw InputError(dir.string() + ": exists and is not a folder");
  }
  const fs::path marker = dir / kMarker;
  if (fs::exists(dir) && !fs::is_empty(dir) && !force) {
    const std::string owner = fs::exists(marker) ? first_line(marker) : std::string();
    if (owner != command) {
      const std::string by = owner.empty() ? "it holds files Kestrel did not write"
                                           : "it holds the output of `kestrel " + owner + "`";
      throw InputError(dir.string() + ": refusing to write into this folder: " + by +
                       " (pass --force, or choose another folder)");
    }
  }
  fs::create_directories(dir);
  std::ofstream out(marker);
  out << command << "\n";
  if (!out) throw InputError(marker.string() + ": cannot write");
}

}  // namespace kestrel::io
