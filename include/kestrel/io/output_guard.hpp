// Protecting the user's files: Kestrel never silently overwrites a file or folder that it did
// not write with the same command, and never writes over one of its own inputs. Every text
// output starts with a provenance line; images have none, so an existing one needs --force.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace kestrel::io {

/// "# written by kestrel <command>": the first line of every text file Kestrel writes.
std::string provenance_line(std::string_view command);

/// Allows writing `path` for `command` if it does not exist, if its first line is
/// provenance_line(command) (a re-run of the same command), or if `force`. Otherwise throws
/// InputError naming the file and what wrote it. Creates missing parent folders and checks
/// that the file can be opened for writing (without changing an existing one), so that an
/// unwritable path is found before the work, not after it.
void check_can_write_file(const std::filesystem::path& path, std::string_view command, bool force);

/// The same for an image or other binary output (PNG, PFM), which has no room for a provenance
/// line: an existing file is replaced only with `force`, whatever wrote it. (Inside a folder
/// claimed with claim_output_dir the command owns the names and writes without this check.)
void check_can_write_binary(const std::filesystem::path& path, bool force);

/// The same for an output folder, recognised by a marker file `.kestrel-output` holding the
/// command's name: a missing or empty folder is created and claimed; a folder claimed by the
/// same command is reused; anything else needs `force`.
void claim_output_dir(const std::filesystem::path& dir, std::string_view command, bool force);

/// All the outputs of one command, checked before any work through the checks above, and
/// against the command's inputs: an output that is an input (the same path, or the same file
/// under another name: std::filesystem::equivalent), two outputs that are one file, or an
/// output folder that holds an input are refused even with `force`, naming both options.
class OutputGuard {
 public:
  OutputGuard(std::string_view command, bool force);

  /// An input file or folder that no output may replace; `option` names it ("--left").
  /// An output file inside an input folder is allowed unless it is an input itself.
  OutputGuard& input(std::string option, const std::filesystem::path& path);
  /// A text output with a provenance line (check_can_write_file).
  OutputGuard& text_file(std::string option, const std::filesystem::path& path);
  /// An image or other binary output (check_can_write_binary).
  OutputGuard& binary_file(std::string option, const std::filesystem::path& path);
  /// An output folder (claim_output_dir): no input may lie inside it.
  OutputGuard& folder(std::string option, const std::filesystem::path& dir);

 private:
  void check_against_inputs(const std::string& option, const std::filesystem::path& path,
                            bool is_folder);

  std::string command_;
  bool force_;
  std::vector<std::pair<std::string, std::filesystem::path>> inputs_;
  std::vector<std::pair<std::string, std::filesystem::path>> outputs_;
};

}  // namespace kestrel::io
