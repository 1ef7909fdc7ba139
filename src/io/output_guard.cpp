// Provenance checks before Kestrel writes a file or folder.
#include "kestrel/io/output_guard.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

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

void create_parent_folders(const fs::path& path) {
  if (!path.has_parent_path()) return;
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) {
    throw InputError(path.string() + ": cannot create its folder " + path.parent_path().string() +
                     ": " + ec.message());
  }
}

// Opens the file for writing without changing it (append mode; a new file is removed again),
// so that a read-only file, folder or file system is found before the work.
void probe_writable(const fs::path& path) {
  const bool existed = fs::exists(path);
  errno = 0;
  std::ofstream out(path, std::ios::app | std::ios::binary);
  if (!out) {
    const int err = errno;
    throw InputError(path.string() + ": cannot be written" +
                     (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
  }
  out.close();
  if (!existed) {
    std::error_code ec;
    fs::remove(path, ec);
  }
}

void check_not_folder(const fs::path& path) {
  if (fs::is_directory(path)) {
    throw InputError(path.string() + ": is a directory; expected a file name to write");
  }
}

// The same file or folder: the same path once made absolute and normal, or, where both exist,
// the same inode (links, bind mounts).
bool same(const fs::path& a, const fs::path& b) {
  std::error_code ea, eb;
  const fs::path ca = fs::weakly_canonical(a, ea);
  const fs::path cb = fs::weakly_canonical(b, eb);
  if (!ea && !eb && ca == cb) return true;
  std::error_code ec;
  return fs::equivalent(a, b, ec) && !ec;  // false (with ec set) where either does not exist
}

// `inner` lies inside the folder `outer` (or is it).
bool inside(const fs::path& inner, const fs::path& outer) {
  std::error_code ec;
  const fs::path i = fs::weakly_canonical(inner, ec);
  const fs::path o = fs::weakly_canonical(outer, ec);
  if (ec) return false;
  auto oi = o.begin();
  auto ii = i.begin();
  for (; oi != o.end(); ++oi, ++ii) {
    if (oi->empty()) continue;  // a trailing separator
    if (ii == i.end() || *ii != *oi) return false;
  }
  return true;
}
}  // namespace

std::string provenance_line(std::string_view command) {
  return "# written by kestrel " + std::string(command);
}

void check_can_write_file(const fs::path& path, std::string_view command, bool force) {
  check_not_folder(path);
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
  create_parent_folders(path);
  probe_writable(path);
}

void check_can_write_binary(const fs::path& path, bool force) {
  check_not_folder(path);
  if (fs::exists(path) && !force) {
    throw InputError(path.string() +
                     ": refusing to overwrite: the file exists, and an image carries no mark of "
                     "what wrote it (pass --force to overwrite it, or choose another name)");
  }
  create_parent_folders(path);
  probe_writable(path);
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
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir.string() + ": cannot create the folder: " + ec.message());
  std::ofstream out(marker);
  out << command << "\n";
  if (!out) throw InputError(marker.string() + ": cannot write");
}

OutputGuard::OutputGuard(std::string_view command, bool force) : command_(command), force_(force) {}

OutputGuard& OutputGuard::input(std::string option, const fs::path& path) {
  if (!path.empty()) inputs_.emplace_back(std::move(option), path);
  return *this;
}

void OutputGuard::check_against_inputs(const std::string& option, const fs::path& path,
                                       bool is_folder) {
  for (const auto& [name, in] : inputs_) {
    if (same(path, in)) {
      throw InputError(option + " " + path.string() + ": is the input " + name + " " + in.string() +
                       "; refusing to write over an input (choose another name)");
    }
    if (is_folder && inside(in, path)) {
      throw InputError(option + " " + path.string() + ": holds the input " + name + " " +
                       in.string() +
                       "; refusing to write into a folder of inputs (choose "
                       "another folder)");
    }
  }
  for (const auto& [name, out] : outputs_) {
    if (same(path, out)) {
      throw InputError(option + " " + path.string() + ": the same file as " + name + " " +
                       out.string() + " (give each output its own name)");
    }
  }
  outputs_.emplace_back(option, path);
}

OutputGuard& OutputGuard::text_file(std::string option, const fs::path& path) {
  if (path.empty()) return *this;
  check_against_inputs(option, path, false);
  check_can_write_file(path, command_, force_);
  return *this;
}

OutputGuard& OutputGuard::binary_file(std::string option, const fs::path& path) {
  if (path.empty()) return *this;
  check_against_inputs(option, path, false);
  check_can_write_binary(path, force_);
  return *this;
}

OutputGuard& OutputGuard::folder(std::string option, const fs::path& dir) {
  if (dir.empty()) return *this;
  check_against_inputs(option, dir, true);
  claim_output_dir(dir, command_, force_);
  return *this;
}

}  // namespace kestrel::io
