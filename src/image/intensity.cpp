// BGR / gray to float intensity, thesis eq. 3.22 (the plain mean of the channels).
#include "kestrel/image/intensity.hpp"

#include <stdexcept>

#include "kestrel/image/row_kernels.hpp"

namespace kestrel::image {

void to_intensity(const cv::Mat& image, cv::Mat& out) {
  if (image.empty()) throw std::invalid_argument("to_intensity: empty image");
  out.create(image.size(), CV_32FC1);
  const int w = image.cols;
  if (image.type() == CV_8UC3) {
    for (int y = 0; y < image.rows; ++y) {
      kernels::bgr_to_intensity_row(image.ptr<std::uint8_t>(y), out.ptr<float>(y), w);
    }
  } else if (image.type() == CV_8UC1) {
    image.convertTo(out, CV_32F, 1.0 / 255.0);
  } else if (image.type() == CV_32FC1) {
    image.copyTo(out);
  } else {
    throw std::invalid_argument("to_intensity: expected CV_8UC3, CV_8UC1 or CV_32FC1 image");
  }
}

}  // namespace kestrel::image
