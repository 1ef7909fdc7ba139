// The stereo front end: on a rectified rig it matches a pair with a known shift and gives the
// depth Z = B f / d; on a raw EuRoC pair it gives exactly what rectification and matching give
// one after the other; bad input is an InputError; a reused frame keeps its buffers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/core.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"
#include "test_data.hpp"

namespace kestrel::sensor {
namespace {

RectifiedStereo small_rig() { return RectifiedStereo::centred(160, 120, 200.0, 0.1); }

// A textured left view and the right view of a fronto-parallel plane at disparity `d`: the
// right image is the left one shifted d pixels to the left.
void shifted_pair(int d, cv::Mat& left, cv::Mat& right) {
  left = cv::Mat(120, 160, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(left, cv::RNG::UNIFORM, 0, 256);
  right = cv::Mat(left.size(), CV_8UC1, cv::Scalar(0));
  left(cv::Rect(d, 0, left.cols - d, left.rows))
      .copyTo(right(cv::Rect(0, 0, left.cols - d, left.rows)));
}

// Same size, type and bytes (kNoDisparity is +inf, which a norm of the difference cannot
// compare).
bool bitwise_equal(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const std::size_t row_bytes = a.cols * a.elemSize();
  for (int v = 0; v < a.rows; ++v) {
    if (std::memcmp(a.ptr(v), b.ptr(v), row_bytes) != 0) return false;
  }
  return true;
}

TEST(StereoFrontEnd, RectifiedPairGivesItsDisparityAndDepth) {
  constexpr int kDisparity = 12;
  cv::Mat left, right;
  shifted_pair(kDisparity, left, right);
  StereoFrontEndOptions options;
  options.compute_depth = true;
  StereoFrontEnd front_end(small_rig(), options);
  EXPECT_FALSE(front_end.rectifies());
  StereoDepthFrame frame;
  front_end.process(42, left, right, frame);
  EXPECT_EQ(frame.t_ns, 42);
  EXPECT_EQ(frame.left_rect.data, left.data) << "a rectified input is used as it is";
  ASSERT_GT(frame.match.fill_rate(), 0.5) << frame.match.describe();
  // The matcher finds the shift (its subpixel fit on white noise wanders a little, and
  // pixels whose right match is in the filled border may go wrong); the depth is exactly
  // Z = B f / d of whatever disparity it found (0, no depth, for d = 0).
  int checked = 0, near_shift = 0;
  for (int v = 0; v < frame.disparity_px.rows; ++v) {
    for (int u = 0; u < frame.disparity_px.cols; ++u) {
      const float d = frame.disparity_px.at<float>(v, u);
      const float z = frame.depth_m.at<float>(v, u);
      if (!has_disparity(d)) {
        EXPECT_EQ(z, 0.0F);
        continue;
      }
      ++checked;
      if (std::abs(d - kDisparity) < 0.5F) ++near_shift;
      EXPECT_FLOAT_EQ(z, d > 0.0F ? 20.0F / d : 0.0F);  // B f = 0.1 m x 200 px
    }
  }
  EXPECT_EQ(checked, static_cast<int>(frame.match.valid));
  EXPECT_GT(near_shift, 0.98 * checked);
  EXPECT_GE(frame.match_ms, 0.0);
}

TEST(StereoFrontEnd, DepthOnlyWhenAskedAndBuffersReused) {
  cv::Mat left, right;
  shifted_pair(8, left, right);
  StereoFrontEnd front_end(small_rig(), StereoFrontEndOptions{});
  StereoDepthFrame frame;
  front_end.process(1, left, right, frame);
  EXPECT_TRUE(frame.depth_m.empty());
  const uchar* disparity = frame.disparity_px.data;
  front_end.process(2, left, right, frame);
  EXPECT_EQ(frame.disparity_px.data, disparity) << "a reused frame reallocated its disparity";
}

TEST(StereoFrontEnd, BadInputIsAnInputError) {
  StereoFrontEnd front_end(small_rig(), StereoFrontEndOptions{});
  StereoDepthFrame frame;
  cv::Mat left, right;
  shifted_pair(8, left, right);
  EXPECT_THROW(front_end.process(1, left, cv::Mat(), frame), InputError);
  EXPECT_THROW(front_end.process(1, left, right(cv::Rect(0, 0, 100, 100)), frame), InputError);
  StereoFrontEndOptions bad;
  bad.matcher.block_size = 4;  // must be odd
  EXPECT_THROW(StereoFrontEnd(small_rig(), bad), InputError);
}

TEST(StereoFrontEnd, RawEurocPairEqualsRectifyThenMatch) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const io::EurocSequence seq(test::shared_data_dir() / "euroc" / "V1_01_easy_part1");
  const StereoCalibration calibration = StereoCalibration::from_euroc(seq);
  StereoFrontEndOptions options;
  options.compute_depth = true;
  StereoFrontEnd front_end(calibration, options);
  EXPECT_TRUE(front_end.rectifies());

  const StereoRectifier rectifier(calibration);
  BlockMatcher matcher(options.matcher, rectifier.rig());
  EXPECT_EQ(front_end.R_rect_left(), rectifier.R_rect_left());
  StereoDepthFrame frame;
  for (const std::size_t i : {std::size_t{0}, std::size_t{20}}) {
    const auto pair = seq.load_stereo(i);
    front_end.process(seq.stereo_timestamp(i), pair.left, pair.right, frame);
    cv::Mat l, r, disparity, depth;
    rectifier.rectify(pair.left, pair.right, l, r);
    const MatchStats stats = matcher.match(l, r, disparity);
    disparity_to_depth(disparity, rectifier.rig(), depth);
    EXPECT_TRUE(bitwise_equal(frame.left_rect, l));
    EXPECT_EQ(frame.match.valid, stats.valid);
    EXPECT_GT(stats.fill_rate(), 0.5);
    EXPECT_TRUE(bitwise_equal(frame.disparity_px, disparity));
    EXPECT_TRUE(bitwise_equal(frame.depth_m, depth));
  }
}

}  // namespace
}  // namespace kestrel::sensor
