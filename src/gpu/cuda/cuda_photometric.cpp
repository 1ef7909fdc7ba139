// The CUDA photometric step's host side: reference points uploaded once per keyframe and
// level, the current image once per frame and level; per iteration only the pose goes up and
// the inside count / normal-equation partials come down.
#include <stdexcept>
#include <vector>

#include "../engines.hpp"
#include "cuda_support.hpp"
#include "launch.hpp"

namespace kestrel::gpu::detail {
namespace {

using cuda::DeviceBuffer;

class CudaPhotometricEngine final : public PhotometricStep::Engine {
 public:
  CudaPhotometricEngine() { cuda::ensure_device(); }

  void set_reference(const odometry::ReferenceLevel& level, StageTiming& timing) override {
    const auto n = static_cast<std::size_t>(level.count);
    const cudaStream_t s = stream_.get();
    events_.start.record(stream_);
    auto up = [&](const std::vector<float>& src, DeviceBuffer<float>& dst) {
      dst.resize(n > 0 ? n : 1);
      if (n > 0) {
        KESTREL_CUDA_CHECK(
            cudaMemcpyAsync(dst.data(), src.data(), n * sizeof(float), cudaMemcpyHostToDevice, s));
      }
    };
    up(level.x, x_);
    up(level.y, y_);
    up(level.z, z_);
    up(level.intensity, intensity_);
    for (std::size_t c = 0; c < 8; ++c) up(level.jac[c], jac_[c]);
    residual_.resize(n > 0 ? n : 1);
    valid_.resize(n > 0 ? n : 1);
    inside_.resize(1);
    partials_.resize(static_cast<std::size_t>(device::normal_equation_blocks(level.count)) *
                     device::kNormalTerms);
    events_.uploaded.record(stream_);
    events_.computed.record(stream_);
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);
    points_ = device::PointsView{};
    points_.x = x_.data();
    points_.y = y_.data();
    points_.z = z_.data();
    points_.intensity = intensity_.data();
    for (std::size_t c = 0; c < 8; ++c) points_.jac[c] = jac_[c].data();
    points_.count = level.count;
    params_.fx = level.fx;
    params_.fy = level.fy;
    params_.cx = level.cx;
    params_.cy = level.cy;
    has_reference_ = true;
  }

  void set_image(const cv::Mat& current, StageTiming& timing) override {
    const cudaStream_t s = stream_.get();
    image_.resize(static_cast<std::size_t>(current.cols) * static_cast<std::size_t>(current.rows));
    const auto row = static_cast<std::size_t>(current.cols) * sizeof(float);
    events_.start.record(stream_);
    KESTREL_CUDA_CHECK(cudaMemcpy2DAsync(image_.data(), row, current.data, current.step, row,
                                         static_cast<std::size_t>(current.rows),
                                         cudaMemcpyHostToDevice, s));
    events_.uploaded.record(stream_);
    events_.computed.record(stream_);
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);
    params_.width = current.cols;
    params_.height = current.rows;
    params_.stride = current.cols;
    has_image_ = true;
  }

  int warp(const float R[9], const float t[3], float alpha, float beta,
           StageTiming& timing) override {
    if (!has_image_ || !has_reference_) {
      throw std::logic_error("PhotometricStep::warp: set_reference and set_image first");
    }
    for (int k = 0; k < 9; ++k) params_.r[k] = R[k];
    for (int k = 0; k < 3; ++k) params_.t[k] = t[k];
    params_.alpha = alpha;
    params_.beta = beta;
    const cudaStream_t s = stream_.get();
    events_.start.record(stream_);
    events_.uploaded.record(stream_);  // the pose travels as a kernel argument
    cuda::launch_warp_residuals(points_, image_.data(), params_, residual_.data(), valid_.data(),
                                inside_.data(), s);
    events_.computed.record(stream_);
    int inside = 0;
    KESTREL_CUDA_CHECK(
        cudaMemcpyAsync(&inside, inside_.data(), sizeof(int), cudaMemcpyDeviceToHost, s));
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);
    return inside;
  }

  void residuals(std::vector<float>& r, std::vector<std::uint8_t>& valid,
                 StageTiming& timing) override {
    const auto n = static_cast<std::size_t>(points_.count);
    r.resize(n);
    valid.resize(n);
    const cudaStream_t s = stream_.get();
    events_.start.record(stream_);
    events_.uploaded.record(stream_);
    events_.computed.record(stream_);
    if (n > 0) {
      KESTREL_CUDA_CHECK(cudaMemcpyAsync(r.data(), residual_.data(), n * sizeof(float),
                                         cudaMemcpyDeviceToHost, s));
      KESTREL_CUDA_CHECK(
          cudaMemcpyAsync(valid.data(), valid_.data(), n, cudaMemcpyDeviceToHost, s));
    }
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);
  }

  NormalEquations normal_equations(float inv_sigma, float tukey_c, StageTiming& timing) override {
    if (!has_reference_) throw std::logic_error("PhotometricStep: no reference set");
    const int blocks = device::normal_equation_blocks(points_.count);
    const cudaStream_t s = stream_.get();
    host_partials_.resize(static_cast<std::size_t>(blocks) * device::kNormalTerms);
    events_.start.record(stream_);
    events_.uploaded.record(stream_);
    cuda::launch_normal_equations(points_, residual_.data(), valid_.data(), inv_sigma, tukey_c,
                                  blocks, partials_.data(), s);
    events_.computed.record(stream_);
    KESTREL_CUDA_CHECK(cudaMemcpyAsync(host_partials_.data(), partials_.data(),
                                       host_partials_.size() * sizeof(float),
                                       cudaMemcpyDeviceToHost, s));
    events_.downloaded.record(stream_);
    stream_.synchronize();
    events_.fill(timing);

    double sums[device::kNormalTerms] = {};
    for (int b = 0; b < blocks; ++b) {
      for (int t = 0; t < device::kNormalTerms; ++t) {
        sums[t] +=
            static_cast<double>(host_partials_[static_cast<std::size_t>(b) * device::kNormalTerms +
                                               static_cast<std::size_t>(t)]);
      }
    }
    NormalEquations ne;
    int term = 0;
    for (int a = 0; a < 8; ++a) {
      for (int b = a; b < 8; ++b, ++term) {
        ne.H(a, b) = sums[term];
        ne.H(b, a) = sums[term];
      }
      ne.g(a) = sums[36 + a];
    }
    ne.cost = sums[device::kCostTerm];
    ne.inliers = static_cast<int>(sums[device::kInlierTerm] + 0.5);
    return ne;
  }

 private:
  cuda::Stream stream_;
  cuda::StageEvents events_;
  DeviceBuffer<float> x_, y_, z_, intensity_, residual_, partials_, image_;
  DeviceBuffer<float> jac_[8];
  DeviceBuffer<std::uint8_t> valid_;
  DeviceBuffer<int> inside_;
  std::vector<float> host_partials_;
  device::PointsView points_;
  device::WarpParams params_;
  bool has_image_ = false;
  bool has_reference_ = false;
};

}  // namespace

std::unique_ptr<PhotometricStep::Engine> make_cuda_photometric_engine() {
  return std::make_unique<CudaPhotometricEngine>();
}

}  // namespace kestrel::gpu::detail
