// Variance of the Laplacian in one pass (sharpness.hpp).
#include "kestrel/image/sharpness.hpp"

#include <algorithm>
#include <stdexcept>

namespace kestrel::image {

double laplacian_variance(const cv::Mat& image) {
  if (image.type() != CV_32FC1 || image.cols < 3 || image.rows < 3) {
    throw std::invalid_argument("laplacian_variance: expected CV_32FC1 of at least 3x3");
  }
  const int w = image.cols;
  const int h = image.rows;
  // Sums per row in float (a row's terms are few and alike in size), across rows in double.
  double sum = 0.0;
  double sum_sq = 0.0;
  for (int y = 1; y < h - 1; ++y) {
    const float* up = image.ptr<float>(y - 1);
    const float* mid = image.ptr<float>(y);
    const float* down = image.ptr<float>(y + 1);
    float row_sum = 0.0F;
    float row_sq = 0.0F;
    for (int x = 1; x < w - 1; ++x) {
      const float l = mid[x - 1] + mid[x + 1] + up[x] + down[x] - 4.0F * mid[x];
      row_sum += l;
      row_sq += l * l;
    }
    sum += static_cast<double>(row_sum);
    sum_sq += static_cast<double>(row_sq);
  }
  const double n = static_cast<double>(w - 2) * static_cast<double>(h - 2);
  const double mean = sum / n;
  return std::max(0.0, sum_sq / n - mean * mean);
}

}  // namespace kestrel::image
