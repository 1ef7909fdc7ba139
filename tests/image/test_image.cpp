// image/: intensity, pyramids (incl. depth across occlusions), gradients, bilinear sampling,
// undistortion maps.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "kestrel/image/gradient.hpp"
#include "kestrel/image/intensity.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/image/sharpness.hpp"
#include "kestrel/image/undistortion.hpp"

namespace kestrel::image {
namespace {

cv::Mat ramp(int w, int h, float a, float b, float c) {
  cv::Mat m(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) m.at<float>(y, x) = a * static_cast<float>(x) + b * static_cast<float>(y) + c;
  }
  return m;
}

TEST(Intensity, MeanOfChannelsInUnitRange) {
  cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(30, 60, 90));
  cv::Mat out;
  to_intensity(bgr, out);
  ASSERT_EQ(out.type(), CV_32FC1);
  EXPECT_NEAR(out.at<float>(1, 1), 60.0F / 255.0F, 1e-6F);
  cv::Mat gray(2, 2, CV_8UC1, cv::Scalar(255));
  to_intensity(gray, out);
  EXPECT_FLOAT_EQ(out.at<float>(0, 0), 1.0F);
  EXPECT_THROW(to_intensity(cv::Mat(2, 2, CV_16UC1), out), std::invalid_argument);
}

TEST(Pyramid, HalvesAndKeepsLinearFunctionsConsistentWithScaledCentres) {
  // A linear image stays linear; the 2x2 mean puts level-1 pixel x at level-0 2x + 0.5,
  // the convention of PinholeCamera::scaled(0.5).
  const cv::Mat img = ramp(64, 48, 0.01F, 0.02F, 0.1F);
  for (PyramidFilter f : {PyramidFilter::kBox, PyramidFilter::kGaussian}) {
    IntensityPyramid pyr;
    pyr.build(img, 3, f);
    ASSERT_EQ(pyr.level(1).size(), cv::Size(32, 24));
    ASSERT_EQ(pyr.level(2).size(), cv::Size(16, 12));
    for (int y = 3; y < 20; ++y) {
      for (int x = 3; x < 28; ++x) {
        const float expected = 0.01F * (2.0F * static_cast<float>(x) + 0.5F) +
                               0.02F * (2.0F * static_cast<float>(y) + 0.5F) + 0.1F;
        EXPECT_NEAR(pyr.level(1).at<float>(y, x), expected, 1e-5F) << to_string(f);
      }
    }
  }
  EXPECT_EQ(pyramid_filter_from_string("gaussian"), PyramidFilter::kGaussian);
  EXPECT_THROW(pyramid_filter_from_string("median"), std::invalid_argument);
}

TEST(Pyramid, DepthIsNotAveragedAcrossOcclusionsOrInvalidPixels) {
  cv::Mat d = (cv::Mat_<float>(2, 8) << 1.0F, 3.0F, 0.0F, 0.0F, 2.0F, 2.02F, NAN, -1.0F,  //
               1.0F, 3.0F, 0.0F, 0.0F, 2.0F, 2.02F, INFINITY, 4.0F);
  cv::Mat out;
  downsample_depth(d, out, 0.03F);
  ASSERT_EQ(out.size(), cv::Size(4, 1));
  EXPECT_FLOAT_EQ(out.at<float>(0, 0), 1.0F);    // foreground only, never 2.0
  EXPECT_FLOAT_EQ(out.at<float>(0, 1), 0.0F);    // all invalid
  EXPECT_NEAR(out.at<float>(0, 2), 2.01F, 1e-6F);  // one surface: averaged
  EXPECT_FLOAT_EQ(out.at<float>(0, 3), 4.0F);    // NaN, negative, inf ignored
}

TEST(Gradient, CentralDifferencesOfARampAreItsSlope) {
  const cv::Mat img = ramp(20, 10, 0.3F, -0.2F, 1.0F);
  cv::Mat gx, gy;
  central_gradients(img, gx, gy);
  EXPECT_NEAR(gx.at<float>(5, 7), 0.3F, 1e-5F);
  EXPECT_NEAR(gy.at<float>(5, 7), -0.2F, 1e-5F);
  EXPECT_EQ(gx.at<float>(0, 7), 0.0F);
  EXPECT_EQ(gy.at<float>(5, 19), 0.0F);
}

TEST(Sharpness, LaplacianVarianceHasItsAnalyticValueAndFallsWithBlur) {
  // A linear ramp has no curvature: its Laplacian is 0 everywhere.
  EXPECT_NEAR(laplacian_variance(ramp(40, 30, 0.01F, -0.02F, 0.5F)), 0.0, 1e-10);
  // A checkerboard of +-a: every neighbour is -I, so the Laplacian is -8 I = +-8a, of variance
  // 64 a^2.
  const double a = 0.25;
  cv::Mat board(30, 40, CV_32FC1);
  for (int y = 0; y < board.rows; ++y) {
    for (int x = 0; x < board.cols; ++x) board.at<float>(y, x) = static_cast<float>((x + y) % 2 == 0 ? a : -a);
  }
  EXPECT_NEAR(laplacian_variance(board), 64.0 * a * a, 1e-6);
  // Blur (a horizontal box, as a sideways motion leaves) lowers it; the ratio of two frames is
  // what the tracker reads.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> grey(0.0F, 1.0F);
  cv::Mat noise(60, 80, CV_32FC1);
  for (int y = 0; y < noise.rows; ++y) {
    for (int x = 0; x < noise.cols; ++x) noise.at<float>(y, x) = grey(rng);
  }
  cv::Mat smooth, blurred;
  cv::GaussianBlur(noise, smooth, cv::Size(5, 5), 1.0);
  cv::blur(smooth, blurred, cv::Size(7, 1));
  EXPECT_LT(laplacian_variance(blurred), 0.5 * laplacian_variance(smooth));
  EXPECT_THROW((void)laplacian_variance(cv::Mat(2, 2, CV_32FC1)), std::invalid_argument);
  EXPECT_THROW((void)laplacian_variance(cv::Mat(5, 5, CV_8UC1)), std::invalid_argument);
}

TEST(Interpolation, BilinearIsExactOnLinearFunctionsAndCheckedAtBorders) {
  const cv::Mat img = ramp(20, 10, 0.3F, -0.2F, 1.0F);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> ux(0.0F, 18.999F), uy(0.0F, 8.999F);
  for (int i = 0; i < 200; ++i) {
    const float x = ux(rng), y = uy(rng);
    const float expected = 0.3F * x - 0.2F * y + 1.0F;
    EXPECT_NEAR(sample_bilinear_unchecked(img.ptr<float>(), img.cols, x, y), expected, 1e-5F);
    EXPECT_NEAR(sample_bilinear(img, x, y), expected, 1e-5F);
  }
  EXPECT_NEAR(sample_bilinear(img, 19.0F, 9.0F), 0.3F * 19 - 0.2F * 9 + 1.0F, 1e-5F);
  EXPECT_TRUE(std::isnan(sample_bilinear(img, -0.1F, 2.0F)));
  EXPECT_TRUE(std::isnan(sample_bilinear(img, 2.0F, 9.01F)));
}

TEST(Undistorter, MapsAgreeWithTheCameraModel) {
  const PinholeCamera fr1({517.3, 516.5, 318.6, 255.3, 640, 480},
                          {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  Undistorter und(fr1);
  EXPECT_FALSE(und.is_identity());
  EXPECT_FALSE(und.undistorted_camera().has_distortion());
  // A distorted image whose intensity encodes the undistorted x coordinate of each pixel:
  // after undistortion, pixel (u, v) must read u.
  cv::Mat img(480, 640, CV_32FC1), depth(480, 640, CV_32FC1);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector2d p = fr1.undistort_pixel({u, v});
      img.at<float>(v, u) = static_cast<float>(p.x());
      depth.at<float>(v, u) = static_cast<float>(p.y());
    }
  }
  cv::Mat out, dout;
  und.undistort_intensity(img, out);
  und.undistort_depth(depth, dout);
  for (int v = 60; v < 420; v += 37) {
    for (int u = 60; u < 580; u += 41) {
      EXPECT_NEAR(out.at<float>(v, u), static_cast<float>(u), 0.05F) << u << "," << v;
      EXPECT_NEAR(dout.at<float>(v, u), static_cast<float>(v), 1.0F) << u << "," << v;
    }
  }
  Undistorter none(PinholeCamera({500, 500, 320, 240, 640, 480}));
  EXPECT_TRUE(none.is_identity());
}

}  // namespace
}  // namespace kestrel::image
