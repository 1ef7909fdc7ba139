// Running a Highway kernel test on every SIMD target a module was compiled for and this CPU
// runs (AVX-512, AVX2, SSE4, ..., NEON under qemu), each against the module's scalar reference.
#pragma once

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <cstdint>
#include <string>
#include <vector>

namespace kestrel::test {

/// Runs body(target) once for each of `targets` (a module's simd_targets(), best first) with
/// Highway's dispatch restricted to it, naming the target in any failure; `dispatched()` (the
/// module's simd_target()) must name it too, which shows that the dispatch took it.
template <class Dispatched, class Body>
void on_every_simd_target(const std::vector<std::int64_t>& targets, Dispatched&& dispatched,
                          Body&& body) {
  for (const std::int64_t target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    SCOPED_TRACE(std::string("SIMD target ") + hwy::TargetName(target));
    ASSERT_STREQ(dispatched(), hwy::TargetName(target));
    body(target);
  }
  hwy::SetSupportedTargetsForTest(0);
}

}  // namespace kestrel::test
