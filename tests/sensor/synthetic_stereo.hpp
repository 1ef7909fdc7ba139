// Synthetic rectified stereo pairs with known disparities, shared by the matcher tests: smooth
// random textures on planes (block matcher), random dots shifted by a constant (semi-global
// matcher).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

namespace kestrel::sensor::synthetic {

/// A smooth random texture (blurred noise), values in [0, 255], CV_32F.
inline cv::Mat texture(int w, int h, std::uint64_t seed) {
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
inline void plane_pair(const cv::Mat& tex, double d0, double slope, cv::Mat& left, cv::Mat& right,
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

/// Random dots: every pixel an independent uniform grey level (blurred a little when
/// `sigma` > 0), CV_8UC1.
inline cv::Mat random_dots(int w, int h, std::uint64_t seed, double sigma = 0.0) {
  cv::Mat m(h, w, CV_8UC1);
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> u(0, 255);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) m.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(u(rng));
  }
  if (sigma > 0.0) cv::GaussianBlur(m, m, cv::Size(0, 0), sigma);
  return m;
}

/// A pair whose true left disparity is `d` everywhere: left(x) = right(x - d), the right view
/// seeing `d` more columns on its right (so left pixels x < d have no match).
inline void shifted_pair(const cv::Mat& wide, int d, cv::Mat& left, cv::Mat& right) {
  const int w = wide.cols - d;
  left = wide(cv::Rect(0, 0, w, wide.rows)).clone();
  right = wide(cv::Rect(d, 0, w, wide.rows)).clone();
}

}  // namespace kestrel::sensor::synthetic
