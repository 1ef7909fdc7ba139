// PhotometricStep: the tracker's own per-iteration kernels on the CPU (odometry/
// alignment_kernels.hpp: what DirectTracker runs), or the CUDA kernels.
#include "kestrel/gpu/photometric_step.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "engines.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"

namespace kestrel::gpu {
namespace {

namespace kernels = odometry::kernels;

}  // namespace

PhotometricStep::PhotometricStep(Backend backend, std::ostream* notice)
    : backend_(resolve_backend(backend, notice)) {
  if (backend_ == Backend::kCuda) cuda_ = detail::make_cuda_photometric_engine();
}

PhotometricStep::~PhotometricStep() = default;

void PhotometricStep::set_reference(const odometry::ReferenceLevel& level) {
  if (level.count < 0 || level.x.size() < static_cast<std::size_t>(level.count) ||
      level.y.size() < static_cast<std::size_t>(level.count) ||
      level.z.size() < static_cast<std::size_t>(level.count) ||
      level.intensity.size() < static_cast<std::size_t>(level.count)) {
    throw std::invalid_argument("PhotometricStep: reference level arrays shorter than its count");
  }
  for (const auto& col : level.jac) {
    if (col.size() < static_cast<std::size_t>(level.count)) {
      throw std::invalid_argument("PhotometricStep: Jacobian column shorter than the count");
    }
  }
  count_ = level.count;
  timing_ = {};
  if (cuda_) {
    cuda_->set_reference(level, timing_);
    return;
  }
  // Copied and padded to whole lanes with zeros, as the tracker keeps its levels.
  const auto padded = static_cast<std::size_t>(kernels::pad_to_lanes(level.count));
  const auto n = static_cast<std::size_t>(level.count);
  auto copy = [&](const std::vector<float>& src, std::vector<float>& dst, float pad) {
    dst.assign(padded, pad);
    std::copy(src.begin(), src.begin() + static_cast<long>(n), dst.begin());
  };
  ref_ = odometry::ReferenceLevel{};
  ref_.fx = level.fx;
  ref_.fy = level.fy;
  ref_.cx = level.cx;
  ref_.cy = level.cy;
  ref_.width = level.width;
  ref_.height = level.height;
  ref_.count = level.count;
  copy(level.x, ref_.x, 0.0F);
  copy(level.y, ref_.y, 0.0F);
  copy(level.z, ref_.z, 1.0F);
  copy(level.intensity, ref_.intensity, 0.0F);
  for (std::size_t c = 0; c < 8; ++c) copy(level.jac[c], ref_.jac[c], 0.0F);
  residual_.assign(padded, 0.0F);
  valid_.assign(padded, 0);
  weight_.assign(padded, 0.0F);
}

void PhotometricStep::set_image(const cv::Mat& current) {
  if (current.type() != CV_32FC1 || current.cols < 2 || current.rows < 2) {
    throw std::invalid_argument("PhotometricStep: the image must be CV_32FC1 of at least 2x2");
  }
  timing_ = {};
  if (cuda_) {
    cuda_->set_image(current, timing_);
    return;
  }
  image_ = current;  // shared header: the caller keeps the image alive for the iteration
}

int PhotometricStep::warp(const SE3& T_cur_ref, float alpha, float beta) {
  timing_ = {};
  const kernels::FloatPose T = kernels::FloatPose::from(T_cur_ref);
  if (cuda_) {
    const float Rr[9] = {T.r00, T.r01, T.r02, T.r10, T.r11, T.r12, T.r20, T.r21, T.r22};
    const float tt[3] = {T.t0, T.t1, T.t2};
    return cuda_->warp(Rr, tt, alpha, beta, timing_);
  }
  if (image_.empty()) throw std::logic_error("PhotometricStep::warp: no image set");
  const auto t0 = std::chrono::steady_clock::now();
  const kernels::PointsView points{ref_.x.data(), ref_.y.data(), ref_.z.data(),
                                   ref_.intensity.data(), ref_.count};
  const kernels::LevelImage image{image_.ptr<float>(),
                                  static_cast<int>(image_.step1()),
                                  image_.cols,
                                  image_.rows,
                                  ref_.fx,
                                  ref_.fy,
                                  ref_.cx,
                                  ref_.cy};
  const int inside =
      kernels::warp_residuals(points, image, T, alpha, beta, residual_.data(), valid_.data());
  timing_.compute_ms = ms_since(t0);
  return inside;
}

void PhotometricStep::residuals(std::vector<float>& r, std::vector<std::uint8_t>& valid) {
  timing_ = {};
  if (cuda_) {
    cuda_->residuals(r, valid, timing_);
    return;
  }
  const auto n = static_cast<long>(count_);
  r.assign(residual_.begin(), residual_.begin() + n);
  valid.assign(valid_.begin(), valid_.begin() + n);
}

void PhotometricStep::valid_abs_residuals(std::vector<float>& out) {
  residuals(scratch_r_, scratch_v_);
  out.clear();
  for (std::size_t i = 0; i < scratch_r_.size(); ++i) {
    if (scratch_v_[i]) out.push_back(std::fabs(scratch_r_[i]));
  }
}

NormalEquations PhotometricStep::normal_equations(float inv_sigma, float tukey_c) {
  timing_ = {};
  if (cuda_) return cuda_->normal_equations(inv_sigma, tukey_c, timing_);
  const auto t0 = std::chrono::steady_clock::now();
  // DirectTracker's weight / cost / inlier pass and normal equations.
  const int n = ref_.count;
  const kernels::WeightSums sums = kernels::tukey_weights(residual_.data(), valid_.data(), n,
                                                          inv_sigma, tukey_c, weight_.data());
  for (int i = n; i < kernels::pad_to_lanes(n); ++i) weight_[static_cast<std::size_t>(i)] = 0.0F;
  const float* J[8];
  for (std::size_t k = 0; k < 8; ++k) J[k] = ref_.jac[k].data();
  NormalEquations ne;
  kernels::accumulate_normal_equations<8>(J, n, weight_.data(), residual_.data(), ne.H, ne.g);
  ne.cost = sums.cost;
  ne.inliers = sums.inliers;
  timing_.compute_ms = ms_since(t0);
  return ne;
}

}  // namespace kestrel::gpu
