// StereoMatcher: the CPU BlockMatcher or the CUDA kernels behind one interface, and the
// translation of BlockMatcherOptions into the kernels' parameters.
#include "kestrel/gpu/stereo_matcher.hpp"

#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "engines.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"

namespace kestrel::gpu {

device::StereoParams stereo_params(const sensor::BlockMatcherOptions& o,
                                   const std::optional<RectifiedStereo>& rig, int width,
                                   int height) {
  o.validate();
  if (rig) rig->validate();
  device::StereoParams p;
  p.width = width;
  p.height = height;
  p.radius = o.block_size / 2;
  p.min_disparity = o.min_disparity;
  p.num = o.max_disparity - o.min_disparity;
  p.census = o.cost == sensor::MatchingCost::kCensus ? 1 : 0;
  p.xsobel = o.prefilter == sensor::Prefilter::kXSobel ? 1 : 0;
  p.prefilter_cap = o.prefilter_cap;
  p.census_radius = o.census_window / 2;
  p.uniqueness = o.uniqueness_ratio;
  p.lr_max_diff = o.lr_max_diff;
  const int block = o.block_size;
  // As sensor::BlockMatcher: mean |central difference| / 2 >= threshold over the window.
  p.texture_min = static_cast<std::uint32_t>(std::ceil(o.texture_threshold * 2.0 * block * block));
  p.subpixel = o.subpixel ? 1 : 0;
  const bool depth_range = o.min_depth_m > 0.0 || std::isfinite(o.max_depth_m);
  if (depth_range && !rig) {
    throw std::invalid_argument(
        "block matcher: a depth range (min_depth_m/max_depth_m) needs a calibrated rig");
  }
  p.d_min_valid = 0.0F;
  p.d_max_valid = sensor::kNoDisparity;
  if (rig) {
    const double bf = rig->baseline_m * rig->f;
    p.d_min_valid = std::isfinite(o.max_depth_m) ? static_cast<float>(bf / o.max_depth_m) : 0.0F;
    p.d_max_valid =
        o.min_depth_m > 0.0 ? static_cast<float>(bf / o.min_depth_m) : sensor::kNoDisparity;
  }
  return p;
}

StereoMatcher::StereoMatcher(sensor::BlockMatcherOptions options,
                             std::optional<RectifiedStereo> rig, Backend backend,
                             std::ostream* notice)
    : options_(options), rig_(rig) {
  (void)stereo_params(options_, rig_, 1, 1);  // validates like BlockMatcher
  backend_ = resolve_backend(backend, notice);
  if (backend_ == Backend::kCuda) {
    cuda_ = detail::make_cuda_stereo_engine(options_, rig_);
  } else {
    cpu_ = std::make_unique<sensor::BlockMatcher>(options_, rig_);
  }
}

StereoMatcher::~StereoMatcher() = default;

namespace {

// sensor::BlockMatcher's input conversion (8-bit grey as is; BGR and float grey converted).
cv::Mat to_gray8(const cv::Mat& image, cv::Mat& buffer, const char* which) {
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

}  // namespace

sensor::MatchStats StereoMatcher::match(const cv::Mat& left, const cv::Mat& right,
                                        cv::Mat& disparity) {
  if (cpu_) {
    const auto t0 = std::chrono::steady_clock::now();
    const sensor::MatchStats stats = cpu_->match(left, right, disparity);
    timing_ = {};
    timing_.compute_ms = ms_since(t0);
    return stats;
  }
  // The same input checks and messages as sensor::BlockMatcher::match.
  if (left.empty() || right.empty()) {
    throw InputError(std::string("stereo: the ") + (left.empty() ? "left" : "right") +
                     " image is empty");
  }
  if (left.size() != right.size()) {
    throw InputError("stereo: the left image is " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " but the right one is " +
                     std::to_string(right.cols) + "x" + std::to_string(right.rows));
  }
  if (rig_ && (rig_->width != left.cols || rig_->height != left.rows)) {
    throw InputError("stereo: the images are " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " but the calibration is for " +
                     std::to_string(rig_->width) + "x" + std::to_string(rig_->height));
  }
  const cv::Mat l = to_gray8(left, gray_l_, "left");
  const cv::Mat r = to_gray8(right, gray_r_, "right");
  timing_ = {};
  return cuda_->match(l, r, disparity, timing_);
}

}  // namespace kestrel::gpu
