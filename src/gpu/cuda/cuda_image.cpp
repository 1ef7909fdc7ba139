// The CUDA pyramids and gradients' host side: one device buffer per level, kept across calls.
#include <stdexcept>
#include <vector>

#include "../engines.hpp"
#include "cuda_support.hpp"
#include "launch.hpp"

namespace kestrel::gpu::detail {
namespace {

using cuda::DeviceBuffer;

std::size_t area(cv::Size s) {
  return static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height);
}

void upload(const cv::Mat& m, DeviceBuffer<float>& d, cudaStream_t s) {
  d.resize(area(m.size()));
  const auto row = static_cast<std::size_t>(m.cols) * sizeof(float);
  KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(d.data(), row, m.data, m.step, row,
                                       static_cast<std::size_t>(m.rows), cudaMemcpyHostToDevice,
                                       s));
}

void download(const DeviceBuffer<float>& d, cv::Size size, cv::Mat& m, cudaStream_t s) {
  m.create(size, CV_32FC1);
  const auto row = static_cast<std::size_t>(size.width) * sizeof(float);
  KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(m.data, m.step, d.data(), row, row,
                                       static_cast<std::size_t>(size.height),
                                       cudaMemcpyDeviceToHost, s));
}

// The sizes of levels 0..levels-1, with image::downsample_*'s checks.
std::vector<cv::Size> level_sizes(const cv::Mat& level0, int levels, const char* what) {
  if (level0.type() != CV_32FC1) {
    throw std::invalid_argument(std::string(what) + ": expected CV_32FC1 of at least 2x2");
  }
  std::vector<cv::Size> sizes{level0.size()};
  for (int l = 1; l < levels; ++l) {
    const cv::Size in = sizes.back();
    if (in.width < 2 || in.height < 2) {
      throw std::invalid_argument(std::string(what) + ": expected CV_32FC1 of at least 2x2");
    }
    sizes.push_back(image::half_size(in));
  }
  return sizes;
}

class CudaImageEngine final : public ImageKernels::Engine {
 public:
  CudaImageEngine() {
    cuda::ensure_device();
    pyramid_gaussian_taps(taps_);
  }

  void intensity_pyramid(const cv::Mat& level0, int levels, image::PyramidFilter filter,
                         std::vector<cv::Mat>& out, StageTiming& timing) override {
    const std::vector<cv::Size> sizes = level_sizes(level0, levels, "downsample_intensity");
    run_pyramid(level0, sizes, out, timing, [&](int l, cudaStream_t s) {
      const cv::Size in = sizes[static_cast<std::size_t>(l - 1)];
      const cv::Size o = sizes[static_cast<std::size_t>(l)];
      const float* src = levels_[static_cast<std::size_t>(l - 1)].data();
      float* dst = levels_[static_cast<std::size_t>(l)].data();
      if (filter == image::PyramidFilter::kGaussian) {
        scratch_.resize(area(in));
        cuda::launch_gaussian_rows(src, in.width, in.height, scratch_.data(), taps_, s);
        cuda::launch_gaussian_columns_mean(scratch_.data(), in.width, in.height, dst, o.width,
                                           o.height, taps_, s);
      } else {
        cuda::launch_mean_2x2(src, in.width, dst, o.width, o.height, s);
      }
    });
  }

  void depth_pyramid(const cv::Mat& level0, int levels, float max_relative_spread,
                     std::vector<cv::Mat>& out, StageTiming& timing) override {
    const std::vector<cv::Size> sizes = level_sizes(level0, levels, "downsample_depth");
    run_pyramid(level0, sizes, out, timing, [&](int l, cudaStream_t s) {
      const cv::Size in = sizes[static_cast<std::size_t>(l - 1)];
      const cv::Size o = sizes[static_cast<std::size_t>(l)];
      cuda::launch_depth_2x2(levels_[static_cast<std::size_t>(l - 1)].data(), in.width,
                             levels_[static_cast<std::size_t>(l)].data(), o.width, o.height,
                             max_relative_spread, s);
    });
  }

  void central_gradients(const cv::Mat& img, cv::Mat& gx, cv::Mat& gy,
                         StageTiming& timing) override {
    if (img.type() != CV_32FC1 || img.cols < 3 || img.rows < 3) {
      throw std::invalid_argument("central_gradients: expected CV_32FC1 of at least 3x3");
    }
    const cudaStream_t s = stream_.get();
    gx_.resize(area(img.size()));
    gy_.resize(area(img.size()));
    events_.start.record(stream_);
    upload(img, gradient_in_, s);
    events_.uploaded.record(stream_);
    cuda::launch_central_gradients(gradient_in_.data(), img.cols, img.rows, gx_.data(), gy_.data(),
                                   s);
    events_.computed.record(stream_);
    download(gx_, img.size(), gx, s);
    download(gy_, img.size(), gy, s);
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);
  }

 private:
  template <typename Step>
  void run_pyramid(const cv::Mat& level0, const std::vector<cv::Size>& sizes,
                   std::vector<cv::Mat>& out, StageTiming& timing, Step step) {
    const cudaStream_t s = stream_.get();
    const int levels = static_cast<int>(sizes.size());
    if (levels_.size() < sizes.size()) levels_.resize(sizes.size());
    for (std::size_t l = 1; l < sizes.size(); ++l) levels_[l].resize(area(sizes[l]));
    out.resize(sizes.size());
    events_.start.record(stream_);
    upload(level0, levels_[0], s);
    events_.uploaded.record(stream_);
    for (int l = 1; l < levels; ++l) step(l, s);
    events_.computed.record(stream_);
    for (std::size_t l = 1; l < sizes.size(); ++l) download(levels_[l], sizes[l], out[l], s);
    events_.downloaded.record(stream_);
    level0.copyTo(out[0]);  // level 0 is the input, as in image::IntensityPyramid
    stream_.synchronize();
    events_.fill(timing);
  }

  cuda::Stream stream_;
  cuda::StageEvents events_;
  std::vector<DeviceBuffer<float>> levels_;
  DeviceBuffer<float> scratch_, gradient_in_, gx_, gy_;
  float taps_[3] = {};
};

}  // namespace

std::unique_ptr<ImageKernels::Engine> make_cuda_image_engine() {
  return std::make_unique<CudaImageEngine>();
}

}  // namespace kestrel::gpu::detail
