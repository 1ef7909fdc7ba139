// The CUDA block matcher's host side: device buffers sized once per image size, the four
// kernels on one stream, CUDA-event timing of upload / kernels / download.
#include <array>

#include "../engines.hpp"
#include "cuda_support.hpp"
#include "launch.hpp"

namespace kestrel::gpu::detail {
namespace {

using cuda::DeviceBuffer;

class CudaStereoEngine final : public StereoMatcher::Engine {
 public:
  CudaStereoEngine(const sensor::BlockMatcherOptions& options,
                   const std::optional<RectifiedStereo>& rig)
      : options_(options), rig_(rig) {
    cuda::ensure_device();
  }

  sensor::MatchStats match(const cv::Mat& left8, const cv::Mat& right8, cv::Mat& disparity,
                           StageTiming& timing) override {
    cuda::ensure_device();
    const int w = left8.cols, h = left8.rows;
    const device::StereoParams p = stereo_params(options_, rig_, w, h);
    const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    left_.resize(pixels);
    right_.resize(pixels);
    gradient_.resize(pixels);
    if (p.census) {
      census_l_.resize(pixels);
      census_r_.resize(pixels);
    } else {
      pre_l_.resize(pixels);
      pre_r_.resize(pixels);
    }
    volume_.resize(pixels * static_cast<std::size_t>(p.num));
    best_.resize(pixels);
    state_.resize(pixels);
    right_min_.resize(pixels);
    disparity_.resize(pixels);
    counts_.resize(device::kStateCount);
    const cudaStream_t s = stream_.get();

    events_.start.record(stream_);
    KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(left_.data(), static_cast<std::size_t>(w), left8.data,
                                         left8.step, static_cast<std::size_t>(w),
                                         static_cast<std::size_t>(h), cudaMemcpyHostToDevice, s));
    KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(right_.data(), static_cast<std::size_t>(w), right8.data,
                                         right8.step, static_cast<std::size_t>(w),
                                         static_cast<std::size_t>(h), cudaMemcpyHostToDevice, s));
    events_.uploaded.record(stream_);
    cuda::launch_stereo_prefilter(left_.data(), right_.data(), p, pre_l_.data(), pre_r_.data(),
                                  census_l_.data(), census_r_.data(), gradient_.data(), s);
    cuda::launch_stereo_cost(pre_l_.data(), pre_r_.data(), census_l_.data(), census_r_.data(), p,
                             volume_.data(), s);
    cuda::launch_stereo_select(volume_.data(), gradient_.data(), p, best_.data(), state_.data(),
                               right_min_.data(), s);
    cuda::launch_stereo_finalize(volume_.data(), right_min_.data(), best_.data(), state_.data(), p,
                                 disparity_.data(), counts_.data(), s);
    events_.computed.record(stream_);
    disparity.create(h, w, CV_32F);
    KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(disparity.data, disparity.step, disparity_.data(),
                                         static_cast<std::size_t>(w) * sizeof(float),
                                         static_cast<std::size_t>(w) * sizeof(float),
                                         static_cast<std::size_t>(h), cudaMemcpyDeviceToHost, s));
    std::array<std::uint32_t, device::kStateCount> counts{};
    KESTREL_CUDA_CHECK(
        cudaMemcpyAsync(counts.data(), counts_.data(), sizeof(counts), cudaMemcpyDeviceToHost, s));
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);

    sensor::MatchStats stats;
    stats.pixels = pixels;
    stats.valid = counts[device::kStateValid];
    stats.unreachable = counts[device::kStateUnreachable];
    stats.rejected_texture = counts[device::kStateLowTexture];
    stats.rejected_uniqueness = counts[device::kStateNotUnique];
    stats.rejected_lr = counts[device::kStateLeftRight];
    stats.rejected_depth = counts[device::kStateDepth];
    return stats;
  }

 private:
  sensor::BlockMatcherOptions options_;
  std::optional<RectifiedStereo> rig_;
  cuda::Stream stream_;
  cuda::StageEvents events_;
  DeviceBuffer<std::uint8_t> left_, right_, pre_l_, pre_r_, gradient_, state_;
  DeviceBuffer<std::uint64_t> census_l_, census_r_;
  DeviceBuffer<std::uint16_t> volume_, right_min_;
  DeviceBuffer<std::int16_t> best_;
  DeviceBuffer<float> disparity_;
  DeviceBuffer<std::uint32_t> counts_;
};

}  // namespace

std::unique_ptr<StereoMatcher::Engine> make_cuda_stereo_engine(
    const sensor::BlockMatcherOptions& options, const std::optional<RectifiedStereo>& rig) {
  return std::make_unique<CudaStereoEngine>(options, rig);
}

}  // namespace kestrel::gpu::detail
