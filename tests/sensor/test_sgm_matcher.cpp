// The semi-global matcher: known answers on synthetic pairs (a shifted random-dot pair gives the
// exact disparity, a square in front of a plane keeps both) and bad options rejected with a
// message naming the field. Its SIMD kernels against the scalar reference:
// test_matcher_kernels.cpp.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"
#include "kestrel/sensor/stereo_matcher.hpp"
#include "synthetic_stereo.hpp"
#include "test_data.hpp"

namespace kestrel::sensor {
namespace {

using synthetic::random_dots;
using synthetic::shifted_pair;

TEST(SgmMatcher, ShiftedRandomDotsGiveTheExactDisparity) {
  for (const int paths : {4, 8}) {
    for (const int d : {0, 5, 17, 40}) {
      cv::Mat l, r;
      shifted_pair(random_dots(180 + d, 90, 3), d, l, r);
      SgmOptions o;
      o.paths = paths;
      o.subpixel = false;
      o.max_disparity = 48;
      const cv::Mat disp = SgmMatcher(o).match(l, r);
      int wrong = 0;
      for (int y = 0; y < disp.rows; ++y) {
        // Where neither census window reaches past the image (beyond, the replicated border
        // of one view meets real texture in the other).
        const int half = o.census_width / 2;
        for (int x = d + half; x < disp.cols - half; ++x) {
          wrong += disp.at<float>(y, x) != float(d) ? 1 : 0;
        }
      }
      EXPECT_EQ(wrong, 0) << paths << " paths, d " << d;
    }
  }
}

TEST(SgmMatcher, SubpixelStaysWithinAHalfPixelOfAnIntegerShift) {
  cv::Mat l, r;
  shifted_pair(random_dots(200, 80, 5, 0.8), 11, l, r);
  const cv::Mat disp = SgmMatcher().match(l, r);
  for (int y = 4; y < disp.rows - 4; ++y) {
    for (int x = 16; x < disp.cols - 4; ++x) {
      ASSERT_NEAR(disp.at<float>(y, x), 11.0F, 0.5F) << x << "," << y;
    }
  }
}

TEST(SgmMatcher, SquareInFrontOfAPlaneKeepsBothDisparities) {
  // Background at d = 6, a 60x60 square at d = 20 (its own texture, in both views).
  const int w = 220, h = 140, d_bg = 6, d_fg = 20;
  const cv::Mat bg = random_dots(w + d_bg, h, 7, 0.7), fg = random_dots(60, 60, 8, 0.7);
  cv::Mat l, r;
  shifted_pair(bg, d_bg, l, r);
  const cv::Rect sq(100, 40, 60, 60);
  fg(cv::Rect(0, 0, 60, 60)).copyTo(l(sq));
  fg(cv::Rect(0, 0, 60, 60)).copyTo(r(cv::Rect(sq.x - d_fg, sq.y, 60, 60)));
  SgmOptions o;
  o.subpixel = false;
  o.max_disparity = 32;
  const cv::Mat disp = SgmMatcher(o).match(l, r);
  EXPECT_EQ(disp.at<float>(70, 130), float(d_fg));
  EXPECT_EQ(disp.at<float>(70, 60), float(d_bg));
  int fg_right = 0, bg_right = 0;
  for (int y = sq.y + 4; y < sq.y + sq.height - 4; ++y) {
    for (int x = sq.x + 4; x < sq.x + sq.width - 4; ++x) fg_right += disp.at<float>(y, x) == d_fg;
    for (int x = 20; x < 60; ++x) bg_right += disp.at<float>(y, x) == d_bg;
  }
  EXPECT_EQ(fg_right, 52 * 52);
  EXPECT_EQ(bg_right, 52 * 40);
}

TEST(SgmMatcher, LeftRightCheckDropsTheOccludedStrip) {
  // The square hides a strip of the background from the right view, on its left side (the
  // left view sees it): those pixels have no true match and the check must remove most.
  const int w = 200, h = 100;
  const cv::Mat bg = random_dots(w + 4, h, 11, 0.7), fg = random_dots(50, 50, 12, 0.7);
  cv::Mat l, r;
  shifted_pair(bg, 4, l, r);
  fg(cv::Rect(0, 0, 50, 50)).copyTo(l(cv::Rect(100, 25, 50, 50)));
  fg(cv::Rect(0, 0, 50, 50)).copyTo(r(cv::Rect(80, 25, 50, 50)));
  SgmOptions o;
  o.max_disparity = 32;
  o.lr_max_diff = 1;
  SgmMatcher m(o);
  cv::Mat disp;
  const MatchStats s = m.match(l, r, disp);
  int kept = 0;
  for (int y = 30; y < 70; ++y) {
    for (int x = 86; x < 98; ++x) kept += has_disparity(disp.at<float>(y, x)) ? 1 : 0;
  }
  EXPECT_LT(kept, 40 * 12 / 4) << s.describe();
  EXPECT_GT(s.rejected_lr, 300U);
}

std::string options_error(const SgmOptions& o) {
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SgmMatcher, BadOptionsAreRejectedWithAMessage) {
  const auto with = [](auto edit) {
    SgmOptions o;
    edit(o);
    return options_error(o);
  };
  EXPECT_EQ(options_error(SgmOptions{}), "(no error)");
  EXPECT_NE(with([](SgmOptions& o) { o.max_disparity = 0; }).find("range is empty"),
            std::string::npos);
  EXPECT_NE(with([](SgmOptions& o) { o.paths = 6; }).find("paths must be 4 or 8, got 6"),
            std::string::npos);
  EXPECT_NE(with([](SgmOptions& o) { o.census_width = 8; }).find("census_width must be odd"),
            std::string::npos);
  EXPECT_NE(
      with([](SgmOptions& o) { o.census = CensusPattern::kFull; }).find("it must have 1 to 32"),
      std::string::npos);
  EXPECT_NE(with([](SgmOptions& o) { o.p2 = 3; }).find("p2 (3) must be >= p1 (12)"),
            std::string::npos);
  EXPECT_NE(with([](SgmOptions& o) { o.speckle_size = -1; }).find("speckle_size"),
            std::string::npos);
  EXPECT_THROW(SgmMatcher(SgmOptions{.paths = 2}), std::invalid_argument);
  SgmMatcher m;
  cv::Mat d;
  EXPECT_THROW(m.match(cv::Mat(10, 10, CV_8U), cv::Mat(10, 12, CV_8U), d), InputError);
  EXPECT_THROW(m.match(cv::Mat(10, 10, CV_16U), cv::Mat(10, 10, CV_16U), d), InputError);
}

TEST(SgmMatcher, OptionsLoadFromYamlAndUnknownKeysAreErrors) {
  const auto dir = test::fresh_temp_dir("sgm_options_yaml");
  SgmOptions o;
  o.paths = 4;
  o.census = CensusPattern::kFull;
  o.census_width = 5;
  o.census_height = 5;
  std::ofstream(dir / "sgm.yaml") << o.to_yaml();
  EXPECT_EQ(SgmOptions::load_yaml(dir / "sgm.yaml").to_yaml(), o.to_yaml());
  std::ofstream(dir / "bad.yaml") << "paths: 8\npenalty: 3\n";
  EXPECT_THROW((void)SgmOptions::load_yaml(dir / "bad.yaml"), InputError);
  std::ofstream(dir / "invalid.yaml") << "paths: 5\n";
  try {
    (void)SgmOptions::load_yaml(dir / "invalid.yaml");
    ADD_FAILURE() << "paths: 5 loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("invalid.yaml"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(StereoMatcher, NamesSelectTheMatcher) {
  StereoMatcherKind kind = StereoMatcherKind::kSad;
  parse_option("sgm", kind);
  EXPECT_EQ(kind, StereoMatcherKind::kSgm);
  EXPECT_EQ(to_string(kind), "sgm");
  EXPECT_THROW(parse_option("bm", kind), std::invalid_argument);
  cv::Mat l, r;
  shifted_pair(random_dots(150, 60, 9, 0.8), 8, l, r);
  for (const auto k :
       {StereoMatcherKind::kSad, StereoMatcherKind::kCensus, StereoMatcherKind::kSgm}) {
    StereoMatcher m(k, BlockMatcherOptions{}, SgmOptions{});
    EXPECT_EQ(m.kind(), k);
    cv::Mat d;
    const MatchStats s = m.match(l, r, d);
    EXPECT_GT(s.fill_rate(), 0.5) << to_string(k);
    EXPECT_NEAR(d.at<float>(30, 75), 8.0F, 0.5F) << to_string(k);
  }
}

TEST(StereoFrontEnd, SelectsTheSemiGlobalMatcher) {
  cv::Mat l, r;
  shifted_pair(random_dots(160 + 6, 80, 13, 0.8), 6, l, r);
  StereoFrontEndOptions o;
  o.matcher.max_disparity = 24;  // the range of either matcher
  o.compute_depth = true;
  o.kind = StereoMatcherKind::kSgm;
  StereoFrontEnd front(RectifiedStereo::centred(l.cols, l.rows, 300.0, 0.1), o);
  EXPECT_EQ(front.matcher().kind(), StereoMatcherKind::kSgm);
  EXPECT_NE(front.matcher().describe().find("disparity=[0,24)"), std::string::npos);
  StereoDepthFrame frame;
  front.process(0, l, r, frame);
  EXPECT_GT(frame.match.fill_rate(), 0.95);
  EXPECT_NEAR(frame.disparity_px.at<float>(40, 80), 6.0F, 0.5F);
  EXPECT_NEAR(frame.depth_m.at<float>(40, 80), 300.0F * 0.1F / 6.0F, 0.5F);
  // Without a kind, the block matcher's cost decides, as configurations written before.
  o.kind.reset();
  o.matcher.cost = MatchingCost::kCensus;
  EXPECT_EQ(
      StereoFrontEnd(RectifiedStereo::centred(l.cols, l.rows, 300.0, 0.1), o).matcher().kind(),
      StereoMatcherKind::kCensus);
  o.kind = StereoMatcherKind::kSgm;
  o.sgm.paths = 5;
  EXPECT_THROW(StereoFrontEnd(RectifiedStereo::centred(l.cols, l.rows, 300.0, 0.1), o), InputError);
}

}  // namespace
}  // namespace kestrel::sensor
