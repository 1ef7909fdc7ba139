// Running the built `kestrel` binary (KESTREL_BINARY) from end-to-end tests: one helper so that
// every CLI test quotes its arguments, captures stdout/stderr and decodes the exit status alike.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace kestrel::test {

/// What one run of the binary gave back.
struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
  /// The last non-empty line of stdout (the machine-readable summary of most commands).
  [[nodiscard]] std::string last_line() const {
    std::string text = out;
    while (!text.empty() && text.back() == '\n') text.pop_back();
    const auto newline = text.rfind('\n');
    return newline == std::string::npos ? text : text.substr(newline + 1);
  }
};

/// `s` single-quoted for /bin/sh.
inline std::string quoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// The whole content of a text file ("" if it cannot be opened).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs `kestrel <arguments>` (arguments already quoted), capturing its output in `scratch`.
inline RunResult run_kestrel(const std::filesystem::path& scratch, const std::string& arguments) {
  const std::filesystem::path out = scratch / "stdout.txt";
  const std::filesystem::path err = scratch / "stderr.txt";
  const std::string command = quoted(KESTREL_BINARY) + " " + arguments + " >" +
                              quoted(out.string()) + " 2>" + quoted(err.string());
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

}  // namespace kestrel::test
