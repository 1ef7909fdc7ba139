// A progress bar on stderr for long runs; silent when stderr is not a terminal (logs, CI).
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace kestrel::cli {

class ProgressBar {
 public:
  /// `total` = 0 means unknown: a counter is shown instead of a bar.
  ProgressBar(std::string label, std::size_t total);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void update(std::size_t done);
  /// Clears the bar line so that the next message starts on a clean line.
  void finish();

 private:
  std::string label_;
  std::size_t total_;
  bool enabled_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace kestrel::cli
