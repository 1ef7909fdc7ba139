// The GPU tests' equality checks: the CUDA kernels and their emulation must give the CPU's
// results bit for bit, and the block matcher's statistics exactly.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/core.hpp>
#include <string>

#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::test {

/// Pixels whose float bits differ (inf == inf, NaN patterns compared as bits).
inline int differing_bits(const cv::Mat& a, const cv::Mat& b) {
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(a.type(), b.type());
  int n = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      n += std::memcmp(&a.at<float>(y, x), &b.at<float>(y, x), sizeof(float)) != 0 ? 1 : 0;
    }
  }
  return n;
}

/// Every count of two block-matching runs equal.
inline void expect_same_stats(const sensor::MatchStats& a, const sensor::MatchStats& b,
                              const std::string& what) {
  EXPECT_EQ(a.pixels, b.pixels) << what;
  EXPECT_EQ(a.valid, b.valid) << what;
  EXPECT_EQ(a.unreachable, b.unreachable) << what;
  EXPECT_EQ(a.rejected_texture, b.rejected_texture) << what;
  EXPECT_EQ(a.rejected_uniqueness, b.rejected_uniqueness) << what;
  EXPECT_EQ(a.rejected_lr, b.rejected_lr) << what;
  EXPECT_EQ(a.rejected_depth, b.rejected_depth) << what;
}

}  // namespace kestrel::test
