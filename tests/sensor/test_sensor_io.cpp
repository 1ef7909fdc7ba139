// Pattern determinism, PFM round trips, stereo calibration files and EuRoC rectification.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/pfm.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "test_data.hpp"

namespace kestrel::sensor {
namespace {

TEST(Pattern, DeterministicPerSeed) {
  PatternOptions o;
  o.width = 320;
  o.height = 180;
  o.lines = 50;
  const cv::Mat a = generate_pattern(o, 7), b = generate_pattern(o, 7), c = generate_pattern(o, 8);
  ASSERT_EQ(a.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
  // Lines cover a fair share of the image, and more lines cover more.
  cv::Mat gray;
  cv::cvtColor(a, gray, cv::COLOR_BGR2GRAY);
  const double covered = cv::countNonZero(gray) / double(gray.total());
  EXPECT_GT(covered, 0.05);
  o.lines = 200;
  cv::cvtColor(generate_pattern(o, 7), gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray) / double(gray.total()), covered);
}

// A line given by a position and an orientation crosses the image (thesis 2.3 names no length):
// a single full line reaches the border at both ends; a short segment far inside does not.
TEST(Pattern, FullLinesCrossTheImageSegmentsDoNot) {
  PatternOptions o;
  o.lines = 1;
  o.width = 320;
  o.height = 180;
  o.colors = PatternColors::kWhite;
  auto border_lit = [](const cv::Mat& p) {
    cv::Mat grey;
    cv::cvtColor(p, grey, cv::COLOR_BGR2GRAY);
    const int w = grey.cols, h = grey.rows;
    return cv::countNonZero(grey.row(0)) + cv::countNonZero(grey.row(h - 1)) +
           cv::countNonZero(grey.col(0)) + cv::countNonZero(grey.col(w - 1));
  };
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const cv::Mat full = generate_pattern(o, seed);
    EXPECT_GE(border_lit(full), 2) << "seed " << seed;
  }
  o.full_lines = false;
  o.min_length_px = 4.0;
  o.max_length_px = 4.0;
  int segments_on_border = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    segments_on_border += border_lit(generate_pattern(o, seed)) > 0 ? 1 : 0;
  }
  EXPECT_LT(segments_on_border, 5);
}

TEST(Pattern, ColourSetsAndBadOptions) {
  PatternOptions o;
  o.width = 64;
  o.height = 64;
  o.colors = PatternColors::kWhite;
  o.antialiased = false;
  const cv::Mat w = generate_pattern(o, 1);
  for (int y = 0; y < w.rows; ++y) {
    for (int x = 0; x < w.cols; ++x) {
      const auto p = w.at<cv::Vec3b>(y, x);
      EXPECT_TRUE(p == cv::Vec3b(0, 0, 0) || p == cv::Vec3b(255, 255, 255));
    }
  }
  EXPECT_THROW(parse_pattern_colors("purple"), InputError);
  o.lines = 0;
  EXPECT_THROW(generate_pattern(o, 1), std::invalid_argument);
  o.lines = 10;
  o.min_length_px = 50;
  o.max_length_px = 10;
  EXPECT_THROW(generate_pattern(o, 1), std::invalid_argument);
}

TEST(Pfm, AHeaderClaimingMoreDataThanTheFileHoldsIsRefusedBeforeAllocating) {
  // Found by fuzz/pfm.cpp: this 58-byte file claims 21111x41111 floats; the reader allocated
  // the 3.5 GB image before finding the data short (out-of-memory under the fuzzer's limit).
  const std::string crash(
      "\x50\x66\x0a\x32\x31\x31\x31\x31\x01\x31\x31\x31\x31\x31\x31\x31"
      "\x31\x31\x31\x31\x31\x00\x48\x0a\x20\x34\x31\x31\x31\x31\xff\x3a"
      "\xff\x3a\x50\x66\x0a\x38\x20\x34\x0a\x32\x31\x31\x31\x31\x31\x31"
      "\x31\xd0\x31\x80\x7f\x32\x32\x31\x31\x31",
      58);
  const auto dir = test::fresh_temp_dir("pfm");
  for (const std::string& text : {crash, std::string("PF\n65536 65536\n-1\n")}) {
    std::ofstream(dir / "big.pfm", std::ios::binary) << text;
    try {
      (void)io::read_pfm(dir / "big.pfm");
      ADD_FAILURE() << "read a short file";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("data ends early"), std::string::npos) << e.what();
    }
  }
}

TEST(Pfm, RoundTripKeepsValuesInfinityAndOrientation) {
  const auto dir = test::fresh_temp_dir("pfm");
  cv::Mat d(3, 4, CV_32F);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) d.at<float>(y, x) = static_cast<float>(10 * y + x) + 0.25F;
  }
  d.at<float>(0, 1) = std::numeric_limits<float>::infinity();
  io::write_pfm(dir / "d.pfm", d);
  const cv::Mat back = io::read_pfm(dir / "d.pfm");
  ASSERT_EQ(back.type(), CV_32FC1);
  ASSERT_EQ(back.size(), d.size());
  EXPECT_TRUE(std::isinf(back.at<float>(0, 1)));
  EXPECT_EQ(back.at<float>(2, 3), d.at<float>(2, 3));
  EXPECT_EQ(back.at<float>(0, 0), 0.25F);
  // Bottom row first in the file: the first float stored is the bottom-left pixel.
  std::ifstream in(dir / "d.pfm", std::ios::binary);
  std::string magic, scale;
  int w = 0, h = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  float first = 0.0F;
  in.read(reinterpret_cast<char*>(&first), 4);
  EXPECT_EQ(magic, "Pf");
  EXPECT_EQ(scale, "-1.0");
  EXPECT_EQ(first, d.at<float>(2, 0));
}

TEST(Pfm, BadFilesGiveClearErrors) {
  const auto dir = test::fresh_temp_dir("pfm_bad");
  std::ofstream(dir / "text.pfm") << "hello";
  EXPECT_THROW(io::read_pfm(dir / "text.pfm"), InputError);
  std::ofstream(dir / "short.pfm") << "Pf\n4 4\n-1.0\n1234";
  try {
    io::read_pfm(dir / "short.pfm");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("short.pfm"), std::string::npos);
  }
  EXPECT_THROW(io::read_pfm(dir / "missing.pfm"), InputError);
  // Never overwrite a file that is not a PFM without force.
  std::ofstream(dir / "notes.pfm") << "my notes";
  EXPECT_THROW(io::write_pfm(dir / "notes.pfm", cv::Mat(2, 2, CV_32F, cv::Scalar(1))), InputError);
}

TEST(StereoCalibrationFile, RoundTripAndMissingField) {
  const auto dir = test::fresh_temp_dir("stereo_calib");
  StereoCalibration c;
  c.left = PinholeCamera({450, 451, 370, 250, 752, 480}, {-0.28, 0.07, 0.0001, -0.00003, 0.0});
  c.right = PinholeCamera({452, 453, 372, 251, 752, 480}, {-0.29, 0.08, 0.0, 0.0, 0.0});
  c.T_left_right =
      SE3(SO3::exp(Eigen::Vector3d(0.001, -0.002, 0.003)), Eigen::Vector3d(0.11, 0.001, -0.0005));
  save_stereo_calibration(dir / "pair.yaml", c, "test");
  const StereoCalibration back = load_stereo_calibration(dir / "pair.yaml");
  EXPECT_NEAR(back.left.fx(), 450.0, 1e-9);
  EXPECT_NEAR(back.right.distortion().k2, 0.08, 1e-12);
  EXPECT_NEAR((back.T_left_right.translation() - c.T_left_right.translation()).norm(), 0.0, 1e-9);

  std::ofstream(dir / "broken.yaml")
      << "stereo_pair:\n  left: {width: 752, height: 480, fy: 1, cx: 1, cy: 1}\n"
         "  right: {width: 752, height: 480, fx: 1, fy: 1, cx: 1, cy: 1}\n"
         "  T_left_right: [1,0,0,0.1, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n";
  try {
    (void)load_stereo_calibration(dir / "broken.yaml");
    FAIL() << "missing fx accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("stereo_pair.left.fx"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "nopose.yaml")
      << "stereo_pair:\n  left: {width: 752, height: 480, fx: 1, fy: 1, cx: 1, cy: 1}\n"
         "  right: {width: 752, height: 480, fx: 1, fy: 1, cx: 1, cy: 1}\n";
  EXPECT_THROW((void)load_stereo_calibration(dir / "nopose.yaml"), InputError);
}

TEST(Rectification, EurocRowsAgree) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const io::EurocSequence seq(test::shared_data_dir() / "euroc" / "V1_01_easy_part1");
  const StereoRectifier rectifier(StereoCalibration::from_euroc(seq));
  const RectifiedStereo& rig = rectifier.rig();
  EXPECT_NEAR(rig.f, 436.2, 0.5);  // the rectified focal length
  EXPECT_NEAR(rig.baseline_m, 0.110, 0.001);
  // Corners of the rectified left view, found again in the rectified right view by normalised
  // cross-correlation over a band of rows: their rows agree within 0.5 px.
  std::vector<double> dy;
  for (const std::size_t i : {std::size_t{0}, std::size_t{30}}) {
    const auto pair = seq.load_stereo(i);
    cv::Mat l, r;
    rectifier.rectify(pair.left, pair.right, l, r);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(l, corners, 150, 0.05, 15, cv::Mat(), 7);
    cv::cornerSubPix(l, corners, {5, 5}, {-1, -1},
                     {cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01});
    constexpr int kHalf = 7, kBand = 6, kMaxDisp = 80;
    for (const auto& c : corners) {
      const int u = cvRound(c.x), v = cvRound(c.y);
      if (u - kHalf - kMaxDisp < 0 || u + kHalf >= l.cols || v - kHalf - kBand < 0 ||
          v + kHalf + kBand >= l.rows)
        continue;
      const cv::Mat templ = l(cv::Rect(u - kHalf, v - kHalf, 2 * kHalf + 1, 2 * kHalf + 1));
      const cv::Mat search = r(cv::Rect(u - kHalf - kMaxDisp, v - kHalf - kBand,
                                        2 * kHalf + 1 + kMaxDisp, 2 * kHalf + 1 + 2 * kBand));
      cv::Mat score;
      cv::matchTemplate(search, templ, score, cv::TM_CCOEFF_NORMED);
      double best = 0.0;
      cv::Point at;
      cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
      if (best < 0.9 || at.y == 0 || at.y == score.rows - 1) continue;
      // Parabola through the peak's column for the subpixel row.
      const float a = score.at<float>(at.y - 1, at.x), b = score.at<float>(at.y, at.x),
                  cc = score.at<float>(at.y + 1, at.x);
      const double sub = 0.5 * double(a - cc) / double(a - 2 * b + cc);
      dy.push_back(at.y + sub - kBand);  // both windows sit on row v: the offset is the row error
    }
  }
  ASSERT_GT(dy.size(), 40U);
  std::sort(dy.begin(), dy.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  const double p90 = std::abs(dy[dy.size() * 9 / 10]);
  EXPECT_LT(p90, 0.5) << "90th percentile of |row difference| over " << dy.size() << " corners";
}

}  // namespace
}  // namespace kestrel::sensor
