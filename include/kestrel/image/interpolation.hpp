// Bilinear interpolation of float32 images (thesis 3.10: every interpolation is bilinear).
#pragma once

#include <cmath>
#include <opencv2/core.hpp>

namespace kestrel::image {

/// How an image is sampled between pixel centres: by the tracker's warp (odometry/
/// alignment_kernels.hpp: Catmull-Rom) and by the rolling-shutter rectification (OpenCV's cubic
/// remap). Bilinear is continuous but its derivative jumps at every integer pixel position;
/// bicubic is C1 (docs/odometry.md, "Still camera").
enum class Interpolation { kBilinear, kBicubic };

/// Bilinear sample of a row-major float image at (x, y), pixel centres at integers. The
/// caller guarantees 0 <= x < width-1 and 0 <= y < height-1 (no bounds checks: hot loops).
inline float sample_bilinear_unchecked(const float* data, int stride, float x, float y) {
  const int x0 = static_cast<int>(x);
  const int y0 = static_cast<int>(y);
  const float ax = x - static_cast<float>(x0);
  const float ay = y - static_cast<float>(y0);
  const float* p = data + static_cast<std::ptrdiff_t>(y0) * stride + x0;
  const float top = p[0] + ax * (p[1] - p[0]);
  const float bottom = p[stride] + ax * (p[stride + 1] - p[stride]);
  return top + ay * (bottom - top);
}

/// Checked version for a CV_32FC1 image: NaN outside [0, w-1] x [0, h-1].
inline float sample_bilinear(const cv::Mat& image, float x, float y) {
  if (!(x >= 0.0F && y >= 0.0F && x <= static_cast<float>(image.cols - 1) &&
        y <= static_cast<float>(image.rows - 1))) {
    return std::nanf("");
  }
  // Clamp the 2x2 block inside the image so that the last row/column can be sampled.
  const int x0 = std::min(static_cast<int>(x), image.cols - 2);
  const int y0 = std::min(static_cast<int>(y), image.rows - 2);
  if (x0 < 0 || y0 < 0) return image.at<float>(static_cast<int>(y), static_cast<int>(x));
  const float ax = x - static_cast<float>(x0);
  const float ay = y - static_cast<float>(y0);
  const float* p = image.ptr<float>(y0) + x0;
  const int stride = static_cast<int>(image.step1());
  const float top = p[0] + ax * (p[1] - p[0]);
  const float bottom = p[stride] + ax * (p[stride + 1] - p[stride]);
  return top + ay * (bottom - top);
}

}  // namespace kestrel::image
