// Image pyramids and gradients with a run-time backend: the functions of src/image on the CPU
// (the reference) or the CUDA kernels. Host images in and out; device buffers are kept across
// calls (no allocation once sized). docs/gpu.md states the tolerances.
#pragma once

#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/gpu/backend.hpp"
#include "kestrel/image/pyramid.hpp"

namespace kestrel::gpu {

class ImageKernels {
 public:
  /// Throws BackendUnavailable for kCuda without a device.
  explicit ImageKernels(Backend backend = Backend::kAuto, std::ostream* notice = &std::cerr);
  ~ImageKernels();
  ImageKernels(const ImageKernels&) = delete;
  ImageKernels& operator=(const ImageKernels&) = delete;

  /// As image::IntensityPyramid::build: levels[0] = level0 (CV_32FC1), each next one
  /// image::downsample_intensity of the previous.
  void intensity_pyramid(const cv::Mat& level0, int levels, image::PyramidFilter filter,
                         std::vector<cv::Mat>& out);
  /// As image::DepthPyramid::build (CV_32FC1 metres, 0 = invalid).
  void depth_pyramid(const cv::Mat& level0_depth_m, int levels, float max_relative_spread,
                     std::vector<cv::Mat>& out);
  /// As image::central_gradients.
  void central_gradients(const cv::Mat& image, cv::Mat& gx, cv::Mat& gy);

  [[nodiscard]] Backend backend() const { return backend_; }
  [[nodiscard]] const StageTiming& last_timing() const { return timing_; }

  class Engine {
   public:
    virtual ~Engine() = default;
    virtual void intensity_pyramid(const cv::Mat& level0, int levels, image::PyramidFilter filter,
                                   std::vector<cv::Mat>& out, StageTiming& timing) = 0;
    virtual void depth_pyramid(const cv::Mat& level0, int levels, float max_relative_spread,
                               std::vector<cv::Mat>& out, StageTiming& timing) = 0;
    virtual void central_gradients(const cv::Mat& image, cv::Mat& gx, cv::Mat& gy,
                                   StageTiming& timing) = 0;
  };

 private:
  Backend backend_;
  std::unique_ptr<Engine> cuda_;
  cv::Mat scratch_;
  StageTiming timing_;
};

/// The 5-tap Gaussian of image::downsample_intensity (sigma 1, OpenCV's float kernel):
/// k[0] centre, k[1], k[2] the sides.
void pyramid_gaussian_taps(float k[3]);

}  // namespace kestrel::gpu
