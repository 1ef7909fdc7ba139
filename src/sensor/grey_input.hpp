// The 8-bit grey view of a matcher's input image, shared by the block and semi-global matchers.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "kestrel/core/error.hpp"

namespace kestrel::sensor {

/// `image` itself when 8-bit grey, else converted into `buffer` (BGR to grey; float grey
/// saturated and rounded). InputError naming `which` ("left"/"right") for an empty image or
/// another type.
inline cv::Mat grey8(const cv::Mat& image, cv::Mat& buffer, const char* which) {
  if (image.empty()) throw InputError(std::string("stereo: the ") + which + " image is empty");
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, buffer, cv::COLOR_BGR2GRAY);
    return buffer;
  }
  if (image.type() == CV_32FC1) {
    image.convertTo(buffer, CV_8U);  // saturating, rounded
    return buffer;
  }
  throw InputError(std::string("stereo: the ") + which +
                   " image must be 8-bit grey, 8-bit BGR or float grey, got OpenCV type " +
                   std::to_string(image.type()));
}

}  // namespace kestrel::sensor
