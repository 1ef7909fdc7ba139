// Block matching with a run-time backend: sensor::BlockMatcher on the CPU (the reference) or
// the CUDA kernels, which implement the whole matcher (SAD with or without the x-Sobel
// prefilter, census, winner-take-all, texture, uniqueness, left-right, subpixel, depth range)
// and give the same disparities bit for bit (docs/gpu.md).
#pragma once

#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "kestrel/gpu/backend.hpp"
#include "kestrel/gpu/device/stereo.hpp"
#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::gpu {

/// The kernels' parameters for a `width` x `height` pair (validates the options and the rig as
/// sensor::BlockMatcher does; throws std::invalid_argument).
device::StereoParams stereo_params(const sensor::BlockMatcherOptions& options,
                                   const std::optional<RectifiedStereo>& rig, int width,
                                   int height);

class StereoMatcher {
 public:
  /// Throws std::invalid_argument for invalid options (as sensor::BlockMatcher),
  /// BackendUnavailable for kCuda without a device.
  explicit StereoMatcher(sensor::BlockMatcherOptions options = {},
                         std::optional<RectifiedStereo> rig = std::nullopt,
                         Backend backend = Backend::kAuto, std::ostream* notice = &std::cerr);
  ~StereoMatcher();
  StereoMatcher(const StereoMatcher&) = delete;
  StereoMatcher& operator=(const StereoMatcher&) = delete;

  /// As sensor::BlockMatcher::match: the LEFT view's disparity (CV_32F, kNoDisparity where
  /// none) of a rectified pair (8-bit grey, 8-bit BGR or float grey in [0, 255]).
  sensor::MatchStats match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);

  [[nodiscard]] Backend backend() const { return backend_; }
  [[nodiscard]] const sensor::BlockMatcherOptions& options() const { return options_; }
  [[nodiscard]] const StageTiming& last_timing() const { return timing_; }

  /// The CUDA implementation (src/gpu/cuda; a stub that throws without CUDA).
  class Engine {
   public:
    virtual ~Engine() = default;
    virtual sensor::MatchStats match(const cv::Mat& left8, const cv::Mat& right8,
                                     cv::Mat& disparity, StageTiming& timing) = 0;
  };

 private:
  sensor::BlockMatcherOptions options_;
  std::optional<RectifiedStereo> rig_;
  Backend backend_;
  std::unique_ptr<sensor::BlockMatcher> cpu_;
  std::unique_ptr<Engine> cuda_;
  cv::Mat gray_l_, gray_r_;
  StageTiming timing_;
};

}  // namespace kestrel::gpu
