// Image gradients by central differences, (I(u+1) - I(u-1)) / 2, in intensity per pixel.
#pragma once

#include <opencv2/core.hpp>

namespace kestrel::image {

/// Gradients of a CV_32FC1 image into `gx`, `gy` (reused when sized right). The one-pixel
/// border is set to 0: central differences are not defined there.
void central_gradients(const cv::Mat& image, cv::Mat& gx, cv::Mat& gy);

}  // namespace kestrel::image
