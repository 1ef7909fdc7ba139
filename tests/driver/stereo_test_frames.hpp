// Known images and packed frames for the driver's tests, built here straight from the format's
// definition (docs/driver.md), independently of the decoder under test.
#pragma once

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace kestrel::test {

/// BGR channel of the filter at (x, y) for a sensor-named phase: the name spells the 2x2 tile
/// row by row ("GRBG": (0,0) G, (1,0) R, (0,1) B, (1,1) G).
inline int tile_channel(const std::string& phase, int x, int y) {
  const char c = phase[static_cast<std::size_t>((y % 2) * 2 + (x % 2))];
  return c == 'B' ? 0 : c == 'G' ? 1 : 2;
}

/// What a sensor with filter tile `phase` records of a BGR image.
inline cv::Mat mosaic_by_hand(const cv::Mat& bgr, const std::string& phase) {
  cv::Mat m(bgr.size(), CV_8UC1);
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      m.at<std::uint8_t>(y, x) = bgr.at<cv::Vec3b>(y, x)[tile_channel(phase, x, y)];
    }
  }
  return m;
}

/// The packed frame: byte `left_byte` of each 16-bit word is the left sample, the other byte
/// the right one; rows `stride` bytes apart (0: 2 * width), padding bytes set to 0xAB.
inline std::vector<std::uint8_t> pack_by_hand(const cv::Mat& left, const cv::Mat& right,
                                              int left_byte, std::size_t stride = 0) {
  const auto w = static_cast<std::size_t>(left.cols);
  if (stride == 0) stride = 2 * w;
  std::vector<std::uint8_t> bytes(stride * static_cast<std::size_t>(left.rows), 0xAB);
  for (int y = 0; y < left.rows; ++y) {
    for (int x = 0; x < left.cols; ++x) {
      const std::size_t word =
          static_cast<std::size_t>(y) * stride + 2 * static_cast<std::size_t>(x);
      bytes[word + static_cast<std::size_t>(left_byte)] = left.at<std::uint8_t>(y, x);
      bytes[word + static_cast<std::size_t>(1 - left_byte)] = right.at<std::uint8_t>(y, x);
    }
  }
  return bytes;
}

/// A smooth colour image whose three channels differ everywhere (so that swapped channels or a
/// wrong phase show as large errors): slow sinusoids of different phase per channel.
inline cv::Mat smooth_bgr(int width, int height, double shift = 0.0) {
  cv::Mat img(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = (x + shift) / 60.0;
      const double v = y / 45.0;
      const double b = 60.0 + 40.0 * std::sin(u + 0.3 * v);
      const double g = 128.0 + 50.0 * std::sin(0.7 * u - v + 1.0);
      const double r = 195.0 + 40.0 * std::cos(0.5 * u + 0.8 * v);
      img.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<std::uint8_t>(b), cv::saturate_cast<std::uint8_t>(g),
                    cv::saturate_cast<std::uint8_t>(r));
    }
  }
  return img;
}

/// Uniform random 8-bit samples: every byte value, no structure a decoder could lean on.
inline cv::Mat random_mosaic(int width, int height, std::uint64_t seed) {
  cv::Mat m(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

/// Largest absolute difference over the pixels at least `border` from the edges.
inline double max_abs_diff_inside(const cv::Mat& a, const cv::Mat& b, int border) {
  const cv::Rect inside(border, border, a.cols - 2 * border, a.rows - 2 * border);
  double max_diff = 0.0;
  cv::Mat diff;
  cv::absdiff(a(inside), b(inside), diff);
  cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
  return max_diff;
}

inline bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

}  // namespace kestrel::test
