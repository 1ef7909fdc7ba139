// Intensity and depth pyramids (thesis 3.10).
#include "kestrel/image/pyramid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "kestrel/image/row_kernels.hpp"

namespace kestrel::image {

std::string_view to_string(PyramidFilter filter) {
  return filter == PyramidFilter::kBox ? "box" : "gaussian";
}

PyramidFilter pyramid_filter_from_string(std::string_view name) {
  if (name == "box") return PyramidFilter::kBox;
  if (name == "gaussian") return PyramidFilter::kGaussian;
  throw std::invalid_argument("pyramid filter '" + std::string(name) +
                              "': expected 'box' or 'gaussian'");
}

cv::Size half_size(cv::Size size) { return {size.width / 2, size.height / 2}; }

namespace {

// 2x2 mean into out (sized half_size(in)).
void mean_2x2(const cv::Mat& in, cv::Mat& out) {
  const cv::Size s = half_size(in.size());
  out.create(s, CV_32FC1);
  for (int y = 0; y < s.height; ++y) {
    kernels::mean_2x2_row(in.ptr<float>(2 * y), in.ptr<float>(2 * y + 1), out.ptr<float>(y),
                          s.width);
  }
}

}  // namespace

void downsample_intensity(const cv::Mat& in, cv::Mat& out, PyramidFilter filter, cv::Mat& scratch) {
  if (in.type() != CV_32FC1 || in.cols < 2 || in.rows < 2) {
    throw std::invalid_argument("downsample_intensity: expected CV_32FC1 of at least 2x2");
  }
  if (filter == PyramidFilter::kGaussian) {
    cv::GaussianBlur(in, scratch, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REFLECT_101);
    mean_2x2(scratch, out);
  } else {
    mean_2x2(in, out);
  }
}

void downsample_depth(const cv::Mat& in, cv::Mat& out, float max_relative_spread) {
  if (in.type() != CV_32FC1 || in.cols < 2 || in.rows < 2) {
    throw std::invalid_argument("downsample_depth: expected CV_32FC1 of at least 2x2");
  }
  const cv::Size s = half_size(in.size());
  out.create(s, CV_32FC1);
  // It runs on every frame when the tracker uses the geometric residual.
  for (int y = 0; y < s.height; ++y) {
    kernels::depth_2x2_row(in.ptr<float>(2 * y), in.ptr<float>(2 * y + 1), out.ptr<float>(y),
                           s.width, max_relative_spread);
  }
}

void IntensityPyramid::build(const cv::Mat& level0, int levels, PyramidFilter filter) {
  level0.copyTo(base());
  build_from_base(levels, filter);
}

cv::Mat& IntensityPyramid::base() {
  if (levels_.empty()) levels_.resize(1);
  return levels_[0];
}

void IntensityPyramid::build_from_base(int levels, PyramidFilter filter) {
  if (levels < 1) throw std::invalid_argument("IntensityPyramid: levels must be >= 1");
  levels_.resize(static_cast<std::size_t>(levels));
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    downsample_intensity(levels_[l - 1], levels_[l], filter, scratch_);
  }
}

void DepthPyramid::build(const cv::Mat& level0_depth_m, int levels, float max_relative_spread) {
  const cv::Mat& in = level0_depth_m;
  const bool fused = levels > 1 && in.type() == CV_32FC1 && in.cols >= 2 && in.rows >= 2 &&
                     (levels_.empty() || in.data != levels_[0].data);
  if (!fused) {
    in.copyTo(base());
    build_from_base(levels, max_relative_spread);
    return;
  }
  // Level 0's copy and level 1 in one pass: each pair of input rows is halved while the copy
  // has just brought it into cache, so the input is read from memory once, not twice.
  levels_.resize(static_cast<std::size_t>(levels));
  cv::Mat& l0 = levels_[0];
  cv::Mat& l1 = levels_[1];
  l0.create(in.size(), CV_32FC1);
  l1.create(half_size(in.size()), CV_32FC1);
  const std::size_t row_bytes = static_cast<std::size_t>(in.cols) * sizeof(float);
  for (int y = 0; y < l1.rows; ++y) {
    const float* r0 = in.ptr<float>(2 * y);
    const float* r1 = in.ptr<float>(2 * y + 1);
    std::memcpy(l0.ptr<float>(2 * y), r0, row_bytes);
    std::memcpy(l0.ptr<float>(2 * y + 1), r1, row_bytes);
    kernels::depth_2x2_row(r0, r1, l1.ptr<float>(y), l1.cols, max_relative_spread);
  }
  if (in.rows % 2 == 1)
    std::memcpy(l0.ptr<float>(in.rows - 1), in.ptr<float>(in.rows - 1), row_bytes);
  downsample_from(2, max_relative_spread);
}

cv::Mat& DepthPyramid::base() {
  if (levels_.empty()) levels_.resize(1);
  return levels_[0];
}

void DepthPyramid::build_from_base(int levels, float max_relative_spread) {
  if (levels < 1) throw std::invalid_argument("DepthPyramid: levels must be >= 1");
  levels_.resize(static_cast<std::size_t>(levels));
  downsample_from(1, max_relative_spread);
}

void DepthPyramid::downsample_from(std::size_t first, float max_relative_spread) {
  for (std::size_t l = first; l < levels_.size(); ++l) {
    downsample_depth(levels_[l - 1], levels_[l], max_relative_spread);
  }
}

}  // namespace kestrel::image
