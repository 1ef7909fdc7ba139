// Stage statistics: percentiles and rates.
#include "kestrel/pipeline/stage_stats.hpp"

#include <algorithm>
#include <cmath>

namespace kestrel::pipeline {

namespace {
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}
}  // namespace

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  // Nearest rank: the smallest value with at least q of the values at or below it.
  const auto n = values.size();
  auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(n)));
  rank = std::clamp<std::size_t>(rank, 1, n);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank - 1),
                   values.end());
  return values[rank - 1];
}

Percentiles summarize(const std::vector<double>& values) {
  Percentiles p;
  if (values.empty()) return p;
  p.p50 = percentile(values, 0.5);
  p.p95 = percentile(values, 0.95);
  p.max = *std::max_element(values.begin(), values.end());
  return p;
}

void StageStats::add_processing(Clock::time_point start, Clock::time_point end) {
  processing_ms.push_back(ms_between(start, end));
  if (processing_ms.size() == 1) first_end_ = end;
  last_end_ = end;
}

void StageStats::add_output(Clock::time_point arrived, Clock::time_point now) {
  ++out;
  latency_ms.push_back(ms_between(arrived, now));
}

double StageStats::rate_hz() const {
  if (processing_ms.size() < 2) return 0.0;
  const double s = std::chrono::duration<double>(last_end_ - first_end_).count();
  return s > 0.0 ? static_cast<double>(processing_ms.size() - 1) / s : 0.0;
}

}  // namespace kestrel::pipeline
