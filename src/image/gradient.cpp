// Central-difference gradients with a zero border.
#include "kestrel/image/gradient.hpp"

#include <stdexcept>

#include "kestrel/image/row_kernels.hpp"

namespace kestrel::image {

void central_gradients(const cv::Mat& image, cv::Mat& gx, cv::Mat& gy) {
  if (image.type() != CV_32FC1 || image.cols < 3 || image.rows < 3) {
    throw std::invalid_argument("central_gradients: expected CV_32FC1 of at least 3x3");
  }
  gx.create(image.size(), CV_32FC1);
  gy.create(image.size(), CV_32FC1);
  const int w = image.cols;
  const int h = image.rows;
  gx.row(0).setTo(0.0F);
  gy.row(0).setTo(0.0F);
  gx.row(h - 1).setTo(0.0F);
  gy.row(h - 1).setTo(0.0F);
  for (int y = 1; y < h - 1; ++y) {
    float* ox = gx.ptr<float>(y);
    float* oy = gy.ptr<float>(y);
    ox[0] = oy[0] = ox[w - 1] = oy[w - 1] = 0.0F;
    kernels::central_gradient_row(image.ptr<float>(y - 1), image.ptr<float>(y),
                                  image.ptr<float>(y + 1), ox, oy, w);
  }
}

}  // namespace kestrel::image
