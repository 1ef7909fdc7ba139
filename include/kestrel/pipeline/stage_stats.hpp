// Per-stage statistics of the real-time pipeline: items in/out/dropped, processing time per
// item, latency (capture arrival -> this stage's output) and throughput. Each stage thread
// owns its StageStats and writes it without locks; it is read after the thread is joined.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

namespace kestrel::pipeline {

using Clock = std::chrono::steady_clock;

/// Nearest-rank percentile (q in [0, 1]) of `values`; 0 when empty.
double percentile(std::vector<double> values, double q);

struct Percentiles {
  double p50 = 0.0, p95 = 0.0, max = 0.0;
};
Percentiles summarize(const std::vector<double>& values);

struct StageStats {
  std::string name;
  std::size_t in = 0;       ///< items taken from the input queue
  std::size_t out = 0;      ///< items handed to the next stage
  std::size_t dropped = 0;  ///< items the input queue discarded (stale, full queue)
  std::size_t failed = 0;   ///< items processed without a usable result (tracking failures)
  std::vector<double> processing_ms;  ///< work time per item
  std::vector<double> latency_ms;     ///< capture arrival -> output, per output item

  /// One item's work: [start, end] on the steady clock.
  void add_processing(Clock::time_point start, Clock::time_point end);
  /// One output item, whose data arrived in the pipeline at `arrived`.
  void add_output(Clock::time_point arrived, Clock::time_point now);

  /// Items finished per second between the first and the last one (0 below two items).
  [[nodiscard]] double rate_hz() const;

 private:
  Clock::time_point first_end_{}, last_end_{};
};

}  // namespace kestrel::pipeline
