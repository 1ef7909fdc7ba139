// The stereo matchers' SIMD kernels against their scalar references on every Highway target this
// CPU has (AVX-512, AVX2, SSE4, SSSE3 and the scalar fallback on x86-64; NEON on AArch64): the
// block matcher's row scans and the semi-global matcher's cost, path and selection kernels give
// the reference's maps and stats bit for bit. A program of its own, linked against the sensor
// module only, so that scripts/check_arm64.sh --quick cross-builds and runs it under qemu.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "block_matcher_kernels.hpp"  // the census kernel and its reference (src/sensor)
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"
#include "simd_targets.hpp"
#include "synthetic_stereo.hpp"

namespace kestrel::sensor {
namespace {

using synthetic::plane_pair;
using synthetic::random_dots;
using synthetic::shifted_pair;
using synthetic::texture;

// ---------------------------------------------------------------------------------------------
// Block matcher

/// Pixels whose disparity values differ in any bit (+inf and NaN compare as bit patterns).
int differing_pixels(const cv::Mat& a, const cv::Mat& b) {
  int n = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      n += std::memcmp(&a.at<float>(y, x), &b.at<float>(y, x), sizeof(float)) != 0;
    }
  }
  return n;
}

bool same_stats(const MatchStats& a, const MatchStats& b) {
  return a.pixels == b.pixels && a.valid == b.valid && a.rejected_texture == b.rejected_texture &&
         a.rejected_uniqueness == b.rejected_uniqueness && a.rejected_lr == b.rejected_lr &&
         a.rejected_depth == b.rejected_depth && a.unreachable == b.unreachable;
}

struct Pair {
  std::string name;
  cv::Mat left, right;
};

/// Noise and blurred noise of awkward sizes (widths that are not a multiple of 8, 16 or 32;
/// 1 x 1), a slanted plane, and a weakly textured plane with and without the projector's lines.
std::vector<Pair> comparison_pairs() {
  std::vector<Pair> pairs;
  std::mt19937 rng(11);
  for (const auto& [w, h] : {std::pair{97, 41}, std::pair{160, 90}, std::pair{1, 1},
                             std::pair{3, 7}, std::pair{17, 3}, std::pair{300, 57}}) {
    cv::Mat l(h, w, CV_8U), r(h, w, CV_8U);
    cv::randu(l, 0, 256);
    for (int y = 0; y < h; ++y) {  // the right view: the left one 5 px on, plus noise
      for (int x = 0; x < w; ++x) {
        r.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(
            l.at<std::uint8_t>(y, std::min(w - 1, x + 5)) + static_cast<int>(rng() % 7) - 3);
      }
    }
    pairs.push_back({"noise " + std::to_string(w) + "x" + std::to_string(h), l, r});
    cv::Mat lb, rb;
    cv::GaussianBlur(l, lb, cv::Size(0, 0), 1.5);
    cv::GaussianBlur(r, rb, cv::Size(0, 0), 1.5);
    pairs.push_back({"blurred noise " + std::to_string(w) + "x" + std::to_string(h), lb, rb});
  }
  {
    cv::Mat l, r, truth;
    plane_pair(texture(320, 120, 9), 4.0, 0.06, l, r, truth);
    pairs.push_back({"slanted plane", l, r});
  }
  {  // the active sensor's view: the projector's lines (thesis 2.3) over a weak texture, on a
     // slanted plane; and the same texture without them (the passive view)
    PatternOptions po;
    po.width = 200;
    po.height = 150;
    po.lines = 40;
    cv::Mat lines;
    cv::cvtColor(generate_pattern(po, 7), lines, cv::COLOR_BGR2GRAY);
    lines.convertTo(lines, CV_32F, 0.6);
    cv::Mat weak = texture(200, 150, 10) * 0.15 + 90.0;
    for (const bool active : {true, false}) {
      cv::Mat l, r, truth;
      plane_pair(active ? cv::Mat(weak + lines) : weak, 6.0, 0.04, l, r, truth);
      l.convertTo(l, CV_8U);
      r.convertTo(r, CV_8U);
      pairs.push_back({active ? "projected lines" : "weak texture", l, r});
    }
  }
  return pairs;
}

struct Case {
  int min_d, max_d, block;
  MatchingCost cost;
  Prefilter prefilter;
  int lr, uniqueness;
  double texture;
  bool subpixel;
  double min_depth_m = 0.0, max_depth_m = std::numeric_limits<double>::infinity();

  [[nodiscard]] BlockMatcherOptions options() const {
    BlockMatcherOptions o;
    o.min_disparity = min_d;
    o.max_disparity = max_d;
    o.block_size = block;
    o.cost = cost;
    o.prefilter = prefilter;
    o.lr_max_diff = lr;
    o.uniqueness_ratio = uniqueness;
    o.texture_threshold = texture;
    o.subpixel = subpixel;
    o.min_depth_m = min_depth_m;
    o.max_depth_m = max_depth_m;
    return o;
  }
  /// A depth range needs a rig of the image's size: f 100 px, baseline 0.1 m (d = 10 / Z).
  [[nodiscard]] std::optional<RectifiedStereo> rig(const cv::Mat& image) const {
    if (min_depth_m == 0.0 && !std::isfinite(max_depth_m)) return std::nullopt;
    return RectifiedStereo::centred(image.cols, image.rows, 100.0, 0.1);
  }
};

// Runs `body` on every SIMD target the block matcher's kernels have for this CPU, best first,
// naming the target in any failure.
template <class Body>
void on_every_simd_target(Body&& body) {
  test::on_every_simd_target(
      block_matching_simd_targets(), [] { return block_matching_simd_target(); },
      [&](std::int64_t) { body(); });
}

/// Each case on each pair: the SIMD kernels on every target against the scalar reference
/// (set_portable), maps and stats bit for bit. One matcher per pair runs on all targets in
/// turn, so a change of target between matches is covered too.
void expect_every_target_gives_the_reference(const std::vector<Pair>& pairs,
                                             const std::vector<Case>& cases) {
  for (const Case& c : cases) {
    const BlockMatcherOptions o = c.options();
    std::vector<BlockMatcher> simd;
    std::vector<cv::Mat> reference(pairs.size());
    std::vector<MatchStats> reference_stats(pairs.size());
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      BlockMatcher portable(o, c.rig(pairs[i].left));
      portable.set_portable(true);
      reference_stats[i] = portable.match(pairs[i].left, pairs[i].right, reference[i]);
      simd.emplace_back(o, c.rig(pairs[i].left));
    }
    on_every_simd_target([&] {
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        cv::Mat d;
        const MatchStats s = simd[i].match(pairs[i].left, pairs[i].right, d);
        EXPECT_EQ(differing_pixels(d, reference[i]), 0) << pairs[i].name << ", " << o.describe();
        EXPECT_TRUE(same_stats(s, reference_stats[i]))
            << pairs[i].name << ", " << o.describe() << ": " << s.describe() << " vs "
            << reference_stats[i].describe();
      }
    });
  }
}

constexpr MatchingCost kSad = MatchingCost::kSad, kCensus = MatchingCost::kCensus;
constexpr Prefilter kSobel = Prefilter::kXSobel, kRaw = Prefilter::kNone;

TEST(BlockMatcher, RunsOnTheBestSimdTargetOfTheCpu) {
  const std::vector<std::int64_t> targets = block_matching_simd_targets();
  ASSERT_FALSE(targets.empty());
  EXPECT_STREQ(block_matching_simd_target(), hwy::TargetName(targets.front()));
#if defined(__x86_64__)
  EXPECT_GE(targets.size(), 2U) << "x86-64 has at least SSSE3 and SSE4, or the scalar fallback";
#endif
}

// The SIMD row scans (the tagged-cost fast row for 32/64 lanes, the general one for other
// lane counts up to 256) must give the scalar reference's maps and stats bit for bit, on
// every compiled target the CPU has (128-bit vectors, 256-bit, AVX-512 capped to 256; in a
// build without -march=native also Highway's scalar fallback, where the matcher runs the
// reference itself).
TEST(BlockMatcher, SimdScansGiveTheScalarReferenceOnEveryTarget) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Case> cases = {
      {0, 64, 9, kSad, kSobel, 1, 10, 0.25, true},  // the defaults
      {0, 64, 9, kSad, kSobel, -1, 0, 0.0, true},   // no checks
      {0, 64, 9, kSad, kSobel, -1, 0, 0.0, false},
      {0, 64, 9, kSad, kSobel, 0, 0, 0.0, true},  // each check alone
      {0, 64, 9, kSad, kSobel, 2, 0, 0.0, true},
      {0, 64, 9, kSad, kSobel, -1, 0, 3.0, false},
      {0, 64, 9, kSad, kSobel, -1, 35, 0.0, false},
      {0, 64, 9, kSad, kSobel, 8, 35, 3.0, true},
      {0, 64, 9, kSad, kSobel, 9, 10, 0.25, true},  // beyond the fast row's diagonal
      {0, 64, 9, kSad, kSobel, -1, 100, 0.0, true},
      {0, 16, 9, kSad, kSobel, 1, 10, 0.25, true},  // 32 lanes, half of them out of range
      {0, 32, 9, kSad, kSobel, 1, 10, 0.25, true},
      {0, 48, 9, kSad, kSobel, 1, 10, 0.25, true},  // 64 lanes, 16 out of range
      {5, 37, 9, kSad, kSobel, 1, 10, 0.25, true},  // a minimum disparity: unreachable pixels
      {16, 80, 5, kSad, kSobel, 1, 10, 0.25, true},
      {0, 100, 9, kSad, kSobel, 1, 10, 0.25, true},  // 128 lanes: the general scan
      {0, 128, 15, kSad, kSobel, 1, 10, 0.25, true},
      {3, 131, 15, kSad, kSobel, -1, 0, 0.0, false},
      {0, 160, 7, kSad, kSobel, 2, 20, 1.0, true},   // 160 lanes
      {0, 256, 5, kSad, kSobel, 1, 10, 0.25, true},  // the general scan's widest
      {0, 300, 5, kSad, kSobel, 1, 10, 0.25, true},  // beyond it: the scalar reference
      {0, 64, 3, kSad, kSobel, 1, 10, 0.25, true},
      {0, 64, 13, kSad, kSobel, 1, 10, 0.25, true},  // tagged costs too large for the fast row
      {0, 64, 9, kSad, kRaw, 1, 10, 0.25, true},     // raw intensities (costs up to 255)
      {0, 64, 15, kSad, kRaw, -1, 0, 0.0, true},
      {0, 32, 3, kSad, kRaw, 1, 10, 0.25, true},  // the fast row with costs up to 255
      {0, 64, 3, kSad, kRaw, 2, 10, 0.0, true},
      {0, 64, 9, kCensus, kSobel, 1, 10, 0.25, true},
      {4, 29, 7, kCensus, kSobel, 2, 15, 0.5, true},
      {0, 64, 9, kCensus, kSobel, -1, 0, 0.0, false},
      {0, 128, 15, kCensus, kSobel, 1, 10, 0.25, true},
      {0, 64, 9, kSad, kSobel, 1, 10, 0.25, true, 1.5, 3.0},  // depth ranges (d = 10 / Z)
      {0, 64, 9, kSad, kSobel, -1, 0, 0.0, true, 0.0, 2.2},
      {0, 128, 9, kSad, kSobel, 1, 10, 0.25, true, 1.2, inf},
      {0, 32, 7, kCensus, kSobel, 1, 10, 0.25, true, 1.8, 2.5},
  };
  expect_every_target_gives_the_reference(comparison_pairs(), cases);
}

// The fast row keeps its per-pixel fields for rows up to 8192 pixels; wider rows take the
// general scan. Both sides of the limit, on every target.
TEST(BlockMatcher, SimdScansGiveTheScalarReferenceOnRowsWiderThanTheFastRows) {
  std::vector<Pair> pairs;
  for (const int w : {8192, 8203}) {
    cv::Mat l, r, truth;
    plane_pair(texture(w, 12, 13), 6.0, 0.001, l, r, truth);
    pairs.push_back({"plane " + std::to_string(w) + "x12", l, r});
  }
  const std::vector<Case> cases = {
      {0, 64, 9, kSad, kSobel, 1, 10, 0.25, true},
      {0, 32, 5, kSad, kSobel, -1, 0, 0.0, true},
      {0, 64, 5, kCensus, kSobel, 1, 10, 0.25, true},
  };
  expect_every_target_gives_the_reference(pairs, cases);
}

// The census cost's signatures (census_window 3, 5, 7: 8, 24 and 48 bits) of rows of every
// length around the vector widths, on random bytes with ties and the extremes 0 and 255: the
// SIMD kernel gives the reference's bits on every target.
TEST(BlockMatcher, CensusSignaturesGiveTheScalarReferenceOnEveryTarget) {
  constexpr int kWidth = 300, kHeight = 7;
  std::mt19937 rng(5);
  std::vector<std::uint8_t> image(static_cast<std::size_t>(kWidth * kHeight));
  for (auto& v : image) {
    const auto r = rng() % 8;  // a quarter 0 or 255, many ties among the rest
    v = static_cast<std::uint8_t>(r == 0 ? 0 : r == 1 ? 255 : 120 + static_cast<int>(rng() % 6));
  }
  on_every_simd_target([&] {
    for (const int cr : {1, 2, 3}) {
      std::array<const std::uint8_t*, 7> rows{};
      for (int k = 0; k <= 2 * cr; ++k) {
        rows[static_cast<std::size_t>(k)] =
            image.data() + static_cast<std::size_t>(k * kWidth) + cr;
      }
      for (const int count :
           {0, 1, 7, 8, 9, 15, 16, 17, 31, 32, 33, 63, 64, 65, 100, kWidth - 2 * cr}) {
        std::vector<std::uint64_t> simd(static_cast<std::size_t>(count) + 1, 0xABCD);
        std::vector<std::uint64_t> reference(simd.size(), 0xABCD);
        kernels::census_signatures(rows.data(), cr, count, simd.data());
        kernels::census_signatures_reference(rows.data(), cr, count, reference.data());
        EXPECT_EQ(simd, reference) << "census window " << 2 * cr + 1 << ", " << count << " pixels";
        if (count > 0) {  // not all zero: the signatures carry bits (the test can see a loss)
          EXPECT_NE(*std::max_element(reference.begin(), reference.end() - 1), 0U);
        }
      }
    }
  });
}

// The census column slide (its own translation unit, compiled for AVX3_DL too) against its
// scalar reference on every target it has for this CPU: random signatures, sums that wrap,
// the fast rows' lane counts and more, every storage order and column scale.
TEST(BlockMatcher, CensusSlideRowGivesTheScalarReferenceOnEveryTarget) {
  const std::vector<std::int64_t> targets = kernels::census_simd_targets();
  ASSERT_FALSE(targets.empty());
  std::mt19937_64 rng(7);
  constexpr int kCols = 37;
  for (const int lanes : {32, 64, 96, 128}) {
    for (const int order : {0, 8, 16}) {
      for (const int scale : {1, 4, 8}) {
        const auto n = static_cast<std::size_t>(kCols * lanes);
        std::vector<std::uint64_t> left(kCols), right(static_cast<std::size_t>(kCols + lanes));
        for (auto& v : left) v = rng() & (rng() % 2 == 0 ? ~0ULL : 0xFFFFFFFFFFFFULL);
        for (auto& v : right) v = rng() % 5 == 0 ? left[rng() % kCols] : rng();
        std::vector<std::uint16_t> sums0(n);
        std::vector<std::uint8_t> ring0(n);
        for (auto& v : sums0) v = static_cast<std::uint16_t>(rng());
        for (auto& v : ring0) v = static_cast<std::uint8_t>(rng() % 65);
        std::vector<std::uint16_t> expected_sums = sums0;
        std::vector<std::uint8_t> expected_ring = ring0;
        kernels::census_slide_row_reference(expected_sums.data(), expected_ring.data(), left.data(),
                                            right.data(), kCols, lanes, scale, order);
        for (const std::int64_t target : targets) {
          hwy::SetSupportedTargetsForTest(target);
          SCOPED_TRACE(std::string("SIMD target ") + hwy::TargetName(target) + ", lanes " +
                       std::to_string(lanes) + ", order " + std::to_string(order) + ", scale " +
                       std::to_string(scale));
          ASSERT_STREQ(kernels::census_target_name(), hwy::TargetName(target));
          std::vector<std::uint16_t> sums = sums0;
          std::vector<std::uint8_t> ring = ring0;
          kernels::census_slide_row(sums.data(), ring.data(), left.data(), right.data(), kCols,
                                    lanes, scale, order);
          EXPECT_EQ(sums, expected_sums);
          EXPECT_EQ(ring, expected_ring);
        }
        hwy::SetSupportedTargetsForTest(0);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Semi-global matcher

/// Every option set the kernels branch on: paths, census patterns, ranges that are not a
/// multiple of a vector, a minimum disparity, odd widths.
std::vector<SgmOptions> kernel_option_sets() {
  std::vector<SgmOptions> sets;
  SgmOptions o;
  sets.push_back(o);
  o.lr_max_diff = 1;
  sets.push_back(o);
  o.paths = 4;
  o.min_disparity = 3;
  o.max_disparity = 40;
  sets.push_back(o);
  o.paths = 8;
  o.census = CensusPattern::kFull;
  o.census_width = 5;
  o.census_height = 5;
  o.p2_gradient = 0;
  o.min_disparity = 0;
  o.max_disparity = 16;
  sets.push_back(o);
  o.census_width = 7;
  o.census_height = 3;
  o.max_disparity = 97;
  o.lr_max_diff = 2;
  o.speckle_size = 20;
  sets.push_back(o);
  return sets;
}

bool same_bits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y) {
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

TEST(SgmMatcher, SimdKernelsMatchTheScalarReferenceOnEveryTarget) {
  const std::vector<std::int64_t> targets = SgmMatcher::simd_targets();
  ASSERT_FALSE(targets.empty());
  const cv::Mat wide = random_dots(173 + 30, 61, 21, 1.0);
  cv::Mat l, r;
  shifted_pair(wide, 9, l, r);
  cv::Mat noise = random_dots(l.cols, l.rows, 22);
  cv::addWeighted(r, 0.9, noise, 0.1, 0.0, r);  // not an exact copy: costs vary
  for (const SgmOptions& o : kernel_option_sets()) {
    SgmMatcher reference(o);
    reference.set_reference(true);
    cv::Mat expected;
    const MatchStats es = reference.match(l, r, expected);
    for (const std::int64_t target : targets) {
      hwy::SetSupportedTargetsForTest(target);
      SCOPED_TRACE(std::string("SIMD target ") + hwy::TargetName(target) + ", " + o.describe());
      ASSERT_STREQ(SgmMatcher::simd_target(), hwy::TargetName(target));
      SgmMatcher simd(o);
      cv::Mat got;
      const MatchStats gs = simd.match(l, r, got);
      EXPECT_TRUE(same_bits(got, expected));
      EXPECT_EQ(gs.valid, es.valid);
      EXPECT_EQ(gs.rejected_lr, es.rejected_lr);
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

// The 8-bit path recursion against the 16-bit one, on every target: the same maps bit for bit
// (and so the same sums behind the winners, the parabola and the check) for every option set
// above (all fit in 8 bits) and one at the limit, census bits + p2 = 254.
TEST(SgmMatcher, EightBitPathsMatchSixteenBitPathsOnEveryTarget) {
  const std::vector<std::int64_t> targets = SgmMatcher::simd_targets();
  ASSERT_FALSE(targets.empty());
  const cv::Mat wide = random_dots(173 + 30, 61, 23, 1.0);
  cv::Mat l, r;
  shifted_pair(wide, 11, l, r);
  cv::Mat noise = random_dots(l.cols, l.rows, 24);
  cv::addWeighted(r, 0.85, noise, 0.15, 0.0, r);
  std::vector<SgmOptions> sets = kernel_option_sets();
  SgmOptions edge;  // the largest penalty that still fits: 31 census bits + 223 = 254
  edge.p2 = 223;
  edge.p1 = 40;
  edge.max_disparity = 96;  // 96 lanes: AVX-512's 64-lane bytes do not divide them
  sets.push_back(edge);
  int eight_bit = 0;
  for (const SgmOptions& o : sets) {
    for (const std::int64_t target : targets) {
      hwy::SetSupportedTargetsForTest(target);
      SCOPED_TRACE(std::string("SIMD target ") + hwy::TargetName(target) + ", " + o.describe());
      SgmMatcher narrow(o), wide16(o);
      wide16.allow_8bit_paths(false);
      EXPECT_FALSE(wide16.runs_8bit_paths());
      if (!narrow.runs_8bit_paths()) continue;
      ++eight_bit;
      cv::Mat got, expected;
      const MatchStats gs = narrow.match(l, r, got);
      const MatchStats es = wide16.match(l, r, expected);
      EXPECT_TRUE(same_bits(got, expected));
      EXPECT_EQ(gs.valid, es.valid);
      EXPECT_EQ(gs.rejected_lr, es.rejected_lr);
      // The same matcher again with the other recursion: its buffers hold the first one's.
      narrow.allow_8bit_paths(false);
      cv::Mat again;
      narrow.match(l, r, again);
      EXPECT_TRUE(same_bits(again, expected));
    }
    hwy::SetSupportedTargetsForTest(0);
  }
  EXPECT_EQ(eight_bit, static_cast<int>(sets.size() * targets.size()));
  EXPECT_TRUE(SgmMatcher().runs_8bit_paths());  // the defaults: 31 + 150 <= 254
}

// Penalties too large for 8-bit path costs (census bits + p2 > 254) fall back to the 16-bit
// recursion, which still matches the scalar reference.
TEST(SgmMatcher, PenaltiesTooLargeForEightBitsFallBackToSixteen) {
  const cv::Mat wide = random_dots(120 + 30, 40, 25, 1.0);
  cv::Mat l, r;
  shifted_pair(wide, 7, l, r);
  SgmOptions o;
  o.p2 = 224;  // 31 + 224 = 255: a path cost could reach the masked value 0xFF
  SgmMatcher simd(o), reference(o);
  EXPECT_FALSE(simd.runs_8bit_paths());
  reference.set_reference(true);
  EXPECT_FALSE(reference.runs_8bit_paths());
  o.p2 = 223;
  EXPECT_TRUE(SgmMatcher(o).runs_8bit_paths());
  o.p2 = 150;
  o.census = CensusPattern::kFull;  // 9 x 7 full would be 62 bits: 5 x 5 full, 24 bits
  o.census_width = o.census_height = 5;
  o.p2 = 231;  // 24 + 231 = 255
  EXPECT_FALSE(SgmMatcher(o).runs_8bit_paths());
  const cv::Mat expected = reference.match(l, r);
  const cv::Mat got = simd.match(l, r);
  EXPECT_TRUE(same_bits(got, expected));
}

}  // namespace
}  // namespace kestrel::sensor
