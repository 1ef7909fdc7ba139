// ImageKernels: src/image's pyramid and gradient functions, or the CUDA kernels.
#include "kestrel/gpu/image_kernels.hpp"

#include <chrono>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "engines.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/image/gradient.hpp"

namespace kestrel::gpu {
void pyramid_gaussian_taps(float k[3]) {
  // image::downsample_intensity: cv::GaussianBlur(5x5, sigma 1) builds this float kernel.
  const cv::Mat g = cv::getGaussianKernel(5, 1.0, CV_32F);
  k[0] = g.at<float>(2);
  k[1] = g.at<float>(1);
  k[2] = g.at<float>(0);
}

ImageKernels::ImageKernels(Backend backend, std::ostream* notice)
    : backend_(resolve_backend(backend, notice)) {
  if (backend_ == Backend::kCuda) cuda_ = detail::make_cuda_image_engine();
}

ImageKernels::~ImageKernels() = default;

void ImageKernels::intensity_pyramid(const cv::Mat& level0, int levels, image::PyramidFilter filter,
                                     std::vector<cv::Mat>& out) {
  if (levels < 1) throw std::invalid_argument("intensity_pyramid: levels must be >= 1");
  timing_ = {};
  if (cuda_) {
    cuda_->intensity_pyramid(level0, levels, filter, out, timing_);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  out.resize(static_cast<std::size_t>(levels));
  level0.copyTo(out[0]);
  for (std::size_t l = 1; l < out.size(); ++l) {
    image::downsample_intensity(out[l - 1], out[l], filter, scratch_);
  }
  timing_.compute_ms = ms_since(t0);
}

void ImageKernels::depth_pyramid(const cv::Mat& level0_depth_m, int levels,
                                 float max_relative_spread, std::vector<cv::Mat>& out) {
  if (levels < 1) throw std::invalid_argument("depth_pyramid: levels must be >= 1");
  timing_ = {};
  if (cuda_) {
    cuda_->depth_pyramid(level0_depth_m, levels, max_relative_spread, out, timing_);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  out.resize(static_cast<std::size_t>(levels));
  level0_depth_m.copyTo(out[0]);
  for (std::size_t l = 1; l < out.size(); ++l) {
    image::downsample_depth(out[l - 1], out[l], max_relative_spread);
  }
  timing_.compute_ms = ms_since(t0);
}

void ImageKernels::central_gradients(const cv::Mat& img, cv::Mat& gx, cv::Mat& gy) {
  timing_ = {};
  if (cuda_) {
    cuda_->central_gradients(img, gx, gy, timing_);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  image::central_gradients(img, gx, gy);
  timing_.compute_ms = ms_since(t0);
}

}  // namespace kestrel::gpu
