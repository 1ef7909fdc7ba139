// Wall-clock milliseconds for the per-stage timings that runs report.
#pragma once

#include <chrono>

namespace kestrel {

/// Milliseconds of std::chrono::steady_clock since `t0`.
inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace kestrel
