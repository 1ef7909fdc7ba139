// Block matcher: exact disparities on synthetic fronto-parallel and slanted planes, the
// checks (left-right, uniqueness, depth range), bad input, Middlebury regression figures, and
// the SIMD row scans against the scalar reference on every SIMD target (the same maps and
// stats, bit for bit).
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/lab/stereo_experiment.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "test_data.hpp"

namespace kestrel::sensor {
namespace {

/// A smooth random texture (blurred noise), values in [0, 255].
cv::Mat texture(int w, int h, std::uint64_t seed) {
  cv::Mat noise(h, w, CV_32F);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0F, 255.0F);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) noise.at<float>(y, x) = u(rng);
  }
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.2);
  cv::normalize(noise, noise, 10, 245, cv::NORM_MINMAX);
  return noise;
}

/// A stereo pair of a plane with disparity d(x) = d0 + slope * x: the right image is the
/// texture, the left one samples it at x - d(x) (bilinear), so the true left disparity is d(x).
void plane_pair(const cv::Mat& tex, double d0, double slope, cv::Mat& left, cv::Mat& right,
                cv::Mat& truth) {
  const int w = tex.cols, h = tex.rows;
  right = tex.clone();
  cv::Mat map_x(h, w, CV_32F), map_y(h, w, CV_32F);
  truth.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double d = d0 + slope * x;
      map_x.at<float>(y, x) = static_cast<float>(x - d);
      map_y.at<float>(y, x) = static_cast<float>(y);
      truth.at<float>(y, x) = x - d >= 0.0 ? static_cast<float>(d) : 0.0F;
    }
  }
  cv::remap(tex, left, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
}

cv::Mat interior(int w, int h, int margin) {
  cv::Mat m(h, w, CV_8U, cv::Scalar(0));
  m(cv::Rect(margin, margin, w - 2 * margin, h - 2 * margin)).setTo(255);
  return m;
}

TEST(BlockMatcher, FrontoParallelIntegerShiftIsExact) {
  const cv::Mat tex = texture(200, 120, 1);
  for (const MatchingCost cost : {MatchingCost::kSad, MatchingCost::kCensus}) {
    for (const double d : {7.0, 23.0}) {
      cv::Mat l, r, truth;
      plane_pair(tex, d, 0.0, l, r, truth);
      BlockMatcherOptions o;
      o.max_disparity = 32;
      o.cost = cost;
      const cv::Mat disp = BlockMatcher(o).match(l, r);
      // Interior pixels whose window lies inside both images.
      const cv::Mat mask = interior(l.cols, l.rows, 40);
      const lab::DisparityScore s = lab::score_disparity(disp, truth, 0.05, mask);
      EXPECT_GT(s.fill_rate(), 0.99) << "d " << d << " " << s.describe();
      EXPECT_LT(s.rms_error_px, 0.02) << "d " << d;
      EXPECT_EQ(s.bad, 0U) << "d " << d << " " << s.describe();
    }
  }
}

TEST(BlockMatcher, FrontoParallelSubpixelShiftIsAccurate) {
  const cv::Mat tex = texture(200, 120, 2);
  for (const double d : {5.25, 12.5, 17.8}) {
    cv::Mat l, r, truth;
    plane_pair(tex, d, 0.0, l, r, truth);
    BlockMatcherOptions o;
    o.max_disparity = 32;
    const cv::Mat disp = BlockMatcher(o).match(l, r);
    const lab::DisparityScore s =
        lab::score_disparity(disp, truth, 0.25, interior(l.cols, l.rows, 40));
    EXPECT_GT(s.fill_rate(), 0.98) << s.describe();
    EXPECT_LT(s.rms_error_px, 0.15) << "d " << d << " " << s.describe();
    EXPECT_LT(s.bad_rate(), 0.05) << "d " << d << " " << s.describe();
  }
}

TEST(BlockMatcher, SlantedPlane) {
  const cv::Mat tex = texture(320, 120, 3);
  cv::Mat l, r, truth;
  plane_pair(tex, 4.0, 0.06, l, r, truth);  // 4 px at the left edge to 23 px at the right
  BlockMatcherOptions o;
  o.max_disparity = 48;
  const cv::Mat disp = BlockMatcher(o).match(l, r);
  const lab::DisparityScore s =
      lab::score_disparity(disp, truth, 0.5, interior(l.cols, l.rows, 30));
  EXPECT_GT(s.fill_rate(), 0.97) << s.describe();
  EXPECT_LT(s.rms_error_px, 0.3) << s.describe();
  EXPECT_LT(s.bad_rate(), 0.05) << s.describe();
}

TEST(BlockMatcher, LeftBorderSearchesReachableDisparities) {
  const cv::Mat tex = texture(160, 80, 4);
  cv::Mat l, r, truth;
  plane_pair(tex, 10.0, 0.0, l, r, truth);
  BlockMatcherOptions o;
  o.max_disparity = 64;  // more than the left columns 10..63 could see with the full range
  const cv::Mat disp = BlockMatcher(o).match(l, r);
  int good = 0;
  for (int y = 20; y < 60; ++y) {
    for (int x = 14; x < 40; ++x) good += std::abs(disp.at<float>(y, x) - 10.0F) < 0.1F;
  }
  EXPECT_GT(good, 40 * 26 * 9 / 10);
  // Columns left of the true disparity have no match in the right view.
  for (int y = 0; y < disp.rows; ++y)
    EXPECT_FALSE(has_disparity(disp.at<float>(y, 0)) && disp.at<float>(y, 0) > 0.5F);
}

TEST(BlockMatcher, TexturelessRegionsAreRejected) {
  cv::Mat flat(80, 160, CV_8U, cv::Scalar(128));
  BlockMatcherOptions o;
  o.max_disparity = 32;
  cv::Mat disp;
  const MatchStats stats = BlockMatcher(o).match(flat, flat, disp);
  EXPECT_EQ(stats.valid, 0U) << stats.describe();
  EXPECT_EQ(stats.pixels, 80U * 160U);
}

TEST(BlockMatcher, DepthRangeDropsFarPoints) {
  const cv::Mat tex = texture(200, 100, 5);
  cv::Mat l, r, truth;
  plane_pair(tex, 8.0, 0.0, l, r, truth);
  const RectifiedStereo rig{400.0, 100.0, 50.0, 0.1, 200, 100};  // d = 8 px <=> Z = 5 m
  BlockMatcherOptions o;
  o.max_disparity = 32;
  o.max_depth_m = 4.0;
  cv::Mat disp;
  const MatchStats stats = BlockMatcher(o, rig).match(l, r, disp);
  EXPECT_GT(stats.rejected_depth, stats.pixels / 2) << stats.describe();
  o.max_depth_m = 6.0;
  const MatchStats kept = BlockMatcher(o, rig).match(l, r, disp);
  EXPECT_LT(kept.rejected_depth, kept.pixels / 100) << kept.describe();
  cv::Mat depth;
  disparity_to_depth(disp, rig, depth);
  EXPECT_NEAR(depth.at<float>(50, 100), 5.0F, 0.05F);  // Z = B f / d
}

TEST(BlockMatcher, ReusesBuffersAcrossFramesAndSizes) {
  BlockMatcherOptions o;
  o.max_disparity = 32;
  BlockMatcher m(o);
  for (const int w : {120, 200, 120}) {
    cv::Mat l, r, truth;
    plane_pair(texture(w, 90, 6), 9.0, 0.0, l, r, truth);
    const cv::Mat disp = m.match(l, r);
    EXPECT_NEAR(disp.at<float>(45, w / 2), 9.0F, 0.05F) << "width " << w;
  }
}

TEST(BlockMatcher, BadInputGivesClearErrors) {
  BlockMatcher m;
  const cv::Mat a(100, 120, CV_8U, cv::Scalar(1)), b(100, 121, CV_8U, cv::Scalar(1));
  try {
    (void)m.match(a, b);
    FAIL() << "different sizes accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("120x100"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("121x100"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)m.match(cv::Mat(), a), InputError);
  EXPECT_THROW((void)m.match(a, cv::Mat()), InputError);
  EXPECT_THROW((void)m.match(cv::Mat(100, 120, CV_16U), a), InputError);
  for (const auto& [lo, hi] : {std::pair{0, 0}, std::pair{10, 5}, std::pair{-1, 16}}) {
    BlockMatcherOptions o;
    o.min_disparity = lo;
    o.max_disparity = hi;
    try {
      BlockMatcher bad(o);
      FAIL() << "range [" << lo << ", " << hi << ") accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("disparity"), std::string::npos) << e.what();
    }
  }
  BlockMatcherOptions even;
  even.block_size = 8;
  EXPECT_THROW(BlockMatcher{even}, std::invalid_argument);
  BlockMatcherOptions huge;
  huge.block_size = 17;
  huge.prefilter = Prefilter::kNone;  // 17^2 * 255 overflows uint16
  EXPECT_THROW(BlockMatcher{huge}, std::invalid_argument);
  BlockMatcherOptions depth;
  depth.max_depth_m = 5.0;  // needs a rig
  EXPECT_THROW(BlockMatcher{depth}, std::invalid_argument);
}

TEST(BlockMatcher, MiddleburyBeatsStereoBmFigures) {
  KESTREL_REQUIRE_DATA("middlebury/tsukuba");
  // The StereoBM figures (block 9): tsukuba 16.0 %, venus 22.6 %; our dense setting
  // (no rejection: a missing disparity counts as bad) must be lower. Teddy runs in the bench.
  const std::pair<const char*, double> cases[] = {{"tsukuba", 0.160}, {"venus", 0.226}};
  for (const auto& [name, bm] : cases) {
    const lab::MiddleburyPair p =
        lab::load_middlebury_pair(test::shared_data_dir() / "middlebury" / name);
    BlockMatcherOptions o;
    o.max_disparity = (p.max_disparity + 16) / 16 * 16;
    o.lr_max_diff = -1;
    o.uniqueness_ratio = 0;
    o.texture_threshold = 0.0;
    const cv::Mat disp = BlockMatcher(o).match(p.left, p.right);
    const lab::DisparityScore s = lab::score_disparity(disp, p.truth_px);
    EXPECT_LT(s.bad_rate(), bm) << name << ": " << s.describe();
  }
}

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
/// 1 x 1), a slanted plane and the rendered views of fig. 2.7.
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
  {  // rendered active and passive views of the fig. 2.7 scene, small
    lab::StereoExperimentOptions o;
    o.width = 200;
    o.height = 150;
    o.f_px = 130.0;
    o.matcher.max_disparity = 32;
    const lab::StereoExperimentResult e = lab::run_stereo_experiment(o);
    pairs.push_back({"rendered active", e.active.frame.left.gray, e.active.frame.right.gray});
    pairs.push_back({"rendered passive", e.passive.frame.left.gray, e.passive.frame.right.gray});
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
  for (const std::int64_t target : block_matching_simd_targets()) {
    hwy::SetSupportedTargetsForTest(target);
    SCOPED_TRACE(std::string("SIMD target ") + hwy::TargetName(target));
    ASSERT_STREQ(block_matching_simd_target(), hwy::TargetName(target));  // the dispatch took it
    body();
  }
  hwy::SetSupportedTargetsForTest(0);
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

}  // namespace
}  // namespace kestrel::sensor
