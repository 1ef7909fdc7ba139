// image/: intensity, pyramids (incl. depth across occlusions), gradients, bilinear sampling,
// undistortion maps.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "kestrel/image/gradient.hpp"
#include "kestrel/image/intensity.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/image/undistortion.hpp"

namespace kestrel::image {
namespace {

cv::Mat ramp(int w, int h, float a, float b, float c) {
  cv::Mat m(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x)
      m.at<float>(y, x) = a * static_cast<float>(x) + b * static_cast<float>(y) + c;
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
  EXPECT_FLOAT_EQ(out.at<float>(0, 0), 1.0F);      // foreground only, never 2.0
  EXPECT_FLOAT_EQ(out.at<float>(0, 1), 0.0F);      // all invalid
  EXPECT_NEAR(out.at<float>(0, 2), 2.01F, 1e-6F);  // one surface: averaged
  EXPECT_FLOAT_EQ(out.at<float>(0, 3), 4.0F);      // NaN, negative, inf ignored
}

// build() copies level 0 and halves it in one pass; it must give what a copy into base()
// followed by build_from_base() gives: odd sizes, a view into a larger image, its own level 0.
TEST(Pyramid, DepthBuildEqualsCopyThenBuildFromBase) {
  cv::Mat big(101, 140, CV_32FC1);
  cv::randu(big, 0.5F, 4.0F);
  big(cv::Rect(3, 5, 20, 30)).setTo(0.0F);
  for (const cv::Mat& in : {big, cv::Mat(big(cv::Rect(1, 2, 77, 63)))}) {
    DepthPyramid built, reference;
    built.build(in, 4);
    in.copyTo(reference.base());
    reference.build_from_base(4);
    ASSERT_EQ(built.levels(), 4);
    for (int l = 0; l < 4; ++l) {
      ASSERT_EQ(built.level(l).size(), reference.level(l).size()) << "level " << l;
      EXPECT_EQ(cv::norm(built.level(l), reference.level(l), cv::NORM_INF), 0.0) << "level " << l;
    }
    const cv::Mat level0 = built.level(0);  // shares the buffer: rebuilding must not corrupt it
    built.build(level0, 4);
    EXPECT_EQ(cv::norm(built.level(0), reference.level(0), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(built.level(3), reference.level(3), cv::NORM_INF), 0.0);
  }
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

// The remap kernels against OpenCV's cv::remap on the same maps: depth (nearest) bit for bit;
// intensity within what OpenCV's 1/32-pixel fixed-point weights lose (at most half a step of
// 1/32 px in x and y times the image's steepest slope), and in place as well as apart.
TEST(Undistorter, AgreesWithOpenCvRemap) {
  const PinholeCamera fr1({517.3, 516.5, 318.6, 255.3, 640, 480},
                          {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  const Undistorter und(fr1);
  cv::Mat img(480, 640, CV_32FC1), depth(480, 640, CV_32FC1);
  cv::randu(depth, 0.5, 4.0);
  depth.at<float>(100, 100) = 0.0F;
  constexpr double kSlope = 0.02;  // per pixel, the steepest of the image below
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      img.at<float>(v, u) = static_cast<float>(0.5 + 0.25 * std::sin(kSlope / 0.25 * u) +
                                               0.2 * std::cos(0.01 * v + 0.003 * u));
    }
  }
  cv::Mat K = (cv::Mat_<double>(3, 3) << 517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1);
  cv::Mat D = (cv::Mat_<double>(1, 5) << 0.2624, -0.9531, -0.0054, 0.0026, 1.1633);
  cv::Mat m1, m2, map_float, nearest, none1, none2;
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, img.size(), CV_16SC2, m1, m2);
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, img.size(), CV_32FC2, map_float, cv::noArray());
  cv::convertMaps(map_float, none1, nearest, none2, CV_16SC2, true);
  cv::Mat cv_img, cv_depth;
  cv::remap(img, cv_img, m1, m2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::remap(depth, cv_depth, nearest, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
            cv::Scalar(0));
  cv::Mat out, dout;
  und.undistort_intensity(img, out);
  und.undistort_depth(depth, dout);
  EXPECT_EQ(cv::norm(dout, cv_depth, cv::NORM_INF), 0.0);
  EXPECT_LE(cv::norm(out, cv_img, cv::NORM_INF), 2.0 * kSlope / 64.0 + 1e-5);
  // In place: the same result.
  cv::Mat in_place = img.clone();
  und.undistort_intensity(in_place, in_place);
  EXPECT_EQ(cv::norm(in_place, out, cv::NORM_INF), 0.0);
  // Not a float image: OpenCV's remap, as before.
  cv::Mat img8, out8, cv_out8;
  img.convertTo(img8, CV_8U, 255.0);
  und.undistort_intensity(img8, out8);
  cv::remap(img8, cv_out8, m1, m2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  EXPECT_EQ(cv::norm(out8, cv_out8, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace kestrel::image
