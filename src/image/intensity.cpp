// BGR / gray to float intensity, thesis eq. 3.22 (the plain mean of the channels).
#include "kestrel/image/intensity.hpp"

#include <stdexcept>

namespace kestrel::image {

void to_intensity(const cv::Mat& image, cv::Mat& out) {
  if (image.empty()) throw std::invalid_argument("to_intensity: empty image");
  out.create(image.size(), CV_32FC1);
  const int w = image.cols;
  if (image.type() == CV_8UC3) {
    constexpr float kScale = 1.0F / (3.0F * 255.0F);
    for (int y = 0; y < image.rows; ++y) {
      const std::uint8_t* in = image.ptr<std::uint8_t>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        const int sum = in[3 * x] + in[3 * x + 1] + in[3 * x + 2];
        o[x] = static_cast<float>(sum) * kScale;
      }
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
