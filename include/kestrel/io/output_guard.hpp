// Protecting the user's files: Kestrel never silently overwrites a file or folder that it did
// not write with the same command. Every text output starts with a provenance line.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace kestrel::io {

/// "# written by kestrel <command>": the first line of every text file Kestrel writes.
std::string provenance_line(std::string_view command);

/// Allows writing `path` for `command` if it does not exist, if its first line is
/// provenance_line(command) (a re-run of the same command), or if `force`. Otherwise throws
/// InputError naming the file and what wrote it. Creates missing parent folders.
void check_can_write_file(const std::filesystem::path& path, std::string_view command,
                          bool force);

/// The same for an output folder, recognised by a marker file `.kestrel-output` holding the
/// command's name: a missing or empty folder is created and claimed; a folder claimed by the
/// same command is reused; anything else needs `force`.
void claim_output_dir(const std::filesystem::path& dir, std::string_view command, bool force);

}  // namespace kestrel::io
