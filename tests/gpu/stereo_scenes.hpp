// Synthetic rectified pairs for the GPU tests: planes at several disparities (occlusions), a
// flat band (no texture), a periodic band (ambiguous) and noise, so that every rejection of
// the block matcher occurs.
#pragma once

#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::gpu::test {

/// Left and right 8-bit views of width x height (seeded).
inline void synthetic_pair(int width, int height, std::uint64_t seed, cv::Mat& left,
                           cv::Mat& right) {
  std::mt19937_64 rng(seed);
  cv::Mat tex(height, width, CV_32F);
  std::uniform_real_distribution<float> u(0.0F, 255.0F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) tex.at<float>(y, x) = u(rng);
  }
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), 1.3);
  cv::normalize(tex, tex, 15, 240, cv::NORM_MINMAX);
  // Rows [h/2, h/2 + 10): a period-6 grating (ambiguous).
  for (int y = height / 2; y < std::min(height, height / 2 + 10); ++y) {
    for (int x = 0; x < width; ++x) tex.at<float>(y, x) = (x / 3) % 2 == 0 ? 60.0F : 190.0F;
  }
  cv::Mat map_x(height, width, CV_32F), map_y(height, width, CV_32F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      // A slanted background plane and a fronto-parallel box in front of it.
      double d = 6.0 + 0.04 * x + 0.02 * y;
      if (x > width / 3 && x < 2 * width / 3 && y > height / 3 && y < 5 * height / 6) d = 27.0;
      map_x.at<float>(y, x) = static_cast<float>(x - d);
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
  cv::Mat l;
  cv::remap(tex, l, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat noise_l(height, width, CV_32F), noise_r(height, width, CV_32F);
  cv::RNG noise(seed);
  noise.fill(noise_l, cv::RNG::NORMAL, 0.0, 2.0);
  noise.fill(noise_r, cv::RNG::NORMAL, 0.0, 2.0);
  cv::Mat(l + noise_l).convertTo(left, CV_8U);
  cv::Mat(tex + noise_r).convertTo(right, CV_8U);
  // Rows [h/4, h/4 + 12): flat and noise-free in both views (no texture).
  const cv::Range flat(height / 4, std::min(height, height / 4 + 12));
  left.rowRange(flat).setTo(128);
  right.rowRange(flat).setTo(128);
}

/// One matcher configuration of the equivalence tests.
struct MatcherCase {
  std::string name;
  sensor::BlockMatcherOptions options;
  std::optional<RectifiedStereo> rig;
};

/// Every option the GPU path implements, one change at a time from the defaults, plus a few
/// combinations (disparity counts that are not whole 32-lane registers, min_disparity > 0).
inline std::vector<MatcherCase> matcher_cases(int width, int height) {
  std::vector<MatcherCase> cases;
  auto add = [&](std::string name, auto edit) {
    MatcherCase c{std::move(name), {}, std::nullopt};
    edit(c);
    cases.push_back(c);
  };
  add("defaults (sad, xsobel, block 9, 0..64, all checks)", [](MatcherCase&) {});
  add("prefilter none, block 7", [](MatcherCase& c) {
    c.options.prefilter = sensor::Prefilter::kNone;
    c.options.block_size = 7;
  });
  add("xsobel cap 15, block 15", [](MatcherCase& c) {
    c.options.prefilter_cap = 15;
    c.options.block_size = 15;
  });
  add("block 3", [](MatcherCase& c) { c.options.block_size = 3; });
  add("census 5", [](MatcherCase& c) { c.options.cost = sensor::MatchingCost::kCensus; });
  add("census 3, block 11", [](MatcherCase& c) {
    c.options.cost = sensor::MatchingCost::kCensus;
    c.options.census_window = 3;
    c.options.block_size = 11;
  });
  add("census 7", [](MatcherCase& c) {
    c.options.cost = sensor::MatchingCost::kCensus;
    c.options.census_window = 7;
  });
  add("disparities 5..45", [](MatcherCase& c) {
    c.options.min_disparity = 5;
    c.options.max_disparity = 45;
  });
  add("disparities 0..100", [](MatcherCase& c) { c.options.max_disparity = 100; });
  add("disparities 16..24 (8)", [](MatcherCase& c) {
    c.options.min_disparity = 16;
    c.options.max_disparity = 24;
  });
  add("no checks", [](MatcherCase& c) {
    c.options.lr_max_diff = -1;
    c.options.uniqueness_ratio = 0;
    c.options.texture_threshold = 0.0;
  });
  add("lr 0, uniqueness 25", [](MatcherCase& c) {
    c.options.lr_max_diff = 0;
    c.options.uniqueness_ratio = 25;
  });
  add("lr 3, texture 2", [](MatcherCase& c) {
    c.options.lr_max_diff = 3;
    c.options.texture_threshold = 2.0;
  });
  add("no subpixel", [](MatcherCase& c) { c.options.subpixel = false; });
  add("census no subpixel, no uniqueness", [](MatcherCase& c) {
    c.options.cost = sensor::MatchingCost::kCensus;
    c.options.subpixel = false;
    c.options.uniqueness_ratio = 0;
  });
  add("depth range with a rig", [&](MatcherCase& c) {
    RectifiedStereo rig;
    rig.f = 400.0;
    rig.cu = width / 2.0;
    rig.cv = height / 2.0;
    rig.baseline_m = 0.1;
    rig.width = width;
    rig.height = height;
    c.rig = rig;
    c.options.min_depth_m = 1.6;  // d <= 25
    c.options.max_depth_m = 4.0;  // d >= 10
  });
  return cases;
}

}  // namespace kestrel::gpu::test
