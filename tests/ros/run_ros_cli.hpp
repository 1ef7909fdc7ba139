// Running the built `kestrel_ros` binary (KESTREL_ROS_BINARY) from tests, as run_cli.hpp runs
// `kestrel`: quoted arguments, captured stdout/stderr, decoded exit status. C++17.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "run_cli.hpp"

namespace kestrel::test {

inline RunResult run_kestrel_ros(const std::filesystem::path& scratch,
                                 const std::string& arguments) {
  const std::filesystem::path out = scratch / "stdout.txt";
  const std::filesystem::path err = scratch / "stderr.txt";
  const std::string command = "timeout 300 " + quoted(KESTREL_ROS_BINARY) + " " + arguments + " >" +
                              quoted(out.string()) + " 2>" + quoted(err.string());
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

/// The first line of a text file ("" if it cannot be read).
inline std::string read_text_first_line(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

/// The last non-empty line of a text.
inline std::string last_line_of(std::string text) {
  while (!text.empty() && text.back() == '\n') text.pop_back();
  const auto newline = text.rfind('\n');
  return newline == std::string::npos ? text : text.substr(newline + 1);
}

}  // namespace kestrel::test
