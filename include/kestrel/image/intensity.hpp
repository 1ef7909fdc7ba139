// Grayscale intensity images for direct alignment: I = (R + G + B) / 3 (thesis eq. 3.22),
// stored as float32 in [0, 1].
#pragma once

#include <opencv2/core.hpp>

namespace kestrel::image {

/// BGR (CV_8UC3), gray (CV_8UC1) or float (CV_32FC1, taken as is) to CV_32FC1 in [0, 1].
/// `out` is reused when it already has the right size and type. Throws std::invalid_argument
/// for other types or an empty image.
void to_intensity(const cv::Mat& image, cv::Mat& out);

}  // namespace kestrel::image
