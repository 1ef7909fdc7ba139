// PhotometricStep: the tracker's warp/residual and normal-equation loops on the CPU (copied
// from DirectTracker, where they are private; keep the two in step), or the CUDA kernels.
#include "kestrel/gpu/photometric_step.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "engines.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/odometry/robust_weights.hpp"

namespace kestrel::gpu {
namespace {

constexpr int kLanes = 8;  // the tracker's accumulation lanes
int pad_to_lanes(int n) { return (n + kLanes - 1) / kLanes * kLanes; }

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// DirectTracker's accumulate_normal_equations<8> (direct_tracker.cpp): float lanes, then double.
void accumulate_normal_equations(const float* const* J, int count, const float* w, const float* r,
                                 odometry::Matrix8d& H, odometry::Vector8d& g) {
  constexpr int C = 8;
  constexpr int kH = C * (C + 1) / 2;
  alignas(32) float acc[kH + C][kLanes] = {};
  const int n = pad_to_lanes(count);
  for (int i = 0; i < n; i += kLanes) {
    float wj[C][kLanes];
    for (int a = 0; a < C; ++a) {
      for (int k = 0; k < kLanes; ++k) wj[a][k] = w[i + k] * J[a][i + k];
    }
    int term = 0;
    for (int a = 0; a < C; ++a) {
      for (int b = a; b < C; ++b, ++term) {
        for (int k = 0; k < kLanes; ++k) acc[term][k] += wj[a][k] * J[b][i + k];
      }
    }
    for (int a = 0; a < C; ++a) {
      for (int k = 0; k < kLanes; ++k) acc[kH + a][k] += wj[a][k] * r[i + k];
    }
  }
  auto sum = [&](int term) {
    double s = 0.0;
    for (int k = 0; k < kLanes; ++k) s += static_cast<double>(acc[term][k]);
    return s;
  };
  int term = 0;
  for (int a = 0; a < C; ++a) {
    for (int b = a; b < C; ++b, ++term) {
      H(a, b) += sum(term);
      if (b != a) H(b, a) += sum(term);
    }
  }
  for (int a = 0; a < C; ++a) g(a) += sum(kH + a);
}

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
  const auto padded = static_cast<std::size_t>(pad_to_lanes(level.count));
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
  const Eigen::Matrix3f R = T_cur_ref.rotation_matrix().cast<float>();
  const Eigen::Vector3f t = T_cur_ref.translation().cast<float>();
  timing_ = {};
  if (cuda_) {
    const float Rr[9] = {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1),
                         R(1, 2), R(2, 0), R(2, 1), R(2, 2)};
    const float tt[3] = {t.x(), t.y(), t.z()};
    return cuda_->warp(Rr, tt, alpha, beta, timing_);
  }
  if (image_.empty()) throw std::logic_error("PhotometricStep::warp: no image set");
  const auto t0 = std::chrono::steady_clock::now();
  // DirectTracker's warp_residuals (direct_tracker.cpp), unchanged.
  const cv::Mat& cur = image_;
  const float r00 = R(0, 0), r01 = R(0, 1), r02 = R(0, 2);
  const float r10 = R(1, 0), r11 = R(1, 1), r12 = R(1, 2);
  const float r20 = R(2, 0), r21 = R(2, 1), r22 = R(2, 2);
  const float t0_ = t.x(), t1 = t.y(), t2 = t.z();
  const float fx = ref_.fx, fy = ref_.fy, cx = ref_.cx, cy = ref_.cy;
  const auto umax = static_cast<float>(cur.cols - 1);
  const auto vmax = static_cast<float>(cur.rows - 1);
  const float* data = cur.ptr<float>();
  const int stride = static_cast<int>(cur.step1());
  const float* px = ref_.x.data();
  const float* py = ref_.y.data();
  const float* pz = ref_.z.data();
  const float* iref = ref_.intensity.data();
  float* res = residual_.data();
  std::uint8_t* val = valid_.data();
  int inside_count = 0;
  for (int i = 0; i < ref_.count; ++i) {
    const float X = r00 * px[i] + r01 * py[i] + r02 * pz[i] + t0_;
    const float Y = r10 * px[i] + r11 * py[i] + r12 * pz[i] + t1;
    const float Z = r20 * px[i] + r21 * py[i] + r22 * pz[i] + t2;
    const float inv_z = 1.0F / Z;
    float u = fx * X * inv_z + cx;
    float v = fy * Y * inv_z + cy;
    // NaN-safe: every comparison with NaN is false.
    const bool inside = Z > 1e-3F && u >= 0.0F && u < umax && v >= 0.0F && v < vmax;
    u = inside ? u : 0.0F;
    v = inside ? v : 0.0F;
    const float ic = image::sample_bilinear_unchecked(data, stride, u, v);
    res[i] = inside ? alpha * ic + beta - iref[i] : 0.0F;
    val[i] = inside ? 1 : 0;
    inside_count += inside ? 1 : 0;
  }
  timing_.compute_ms = ms_since(t0);
  return inside_count;
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
  // DirectTracker's weight / cost / inlier loop and accumulate_normal_equations.
  const float c = tukey_c;
  const float max_cost = c * c / 6.0F;
  const int n = ref_.count;
  const float* r = residual_.data();
  const std::uint8_t* val = valid_.data();
  float* w = weight_.data();
  NormalEquations ne;
  double cost = 0.0;
  int inliers = 0;
  const auto inv_sigma2 = inv_sigma * inv_sigma;
  for (int i = 0; i < n; ++i) {
    const float u = r[i] * inv_sigma;
    w[i] = val[i] ? odometry::tukey_weight(u, c) * inv_sigma2 : 0.0F;
    cost += static_cast<double>(val[i] ? odometry::tukey_cost(u, c) : max_cost);
    inliers += (val[i] && std::fabs(u) < c) ? 1 : 0;
  }
  for (int i = n; i < pad_to_lanes(n); ++i) w[i] = 0.0F;
  const float* J[8];
  for (std::size_t k = 0; k < 8; ++k) J[k] = ref_.jac[k].data();
  accumulate_normal_equations(J, n, w, r, ne.H, ne.g);
  ne.cost = cost;
  ne.inliers = inliers;
  timing_.compute_ms = ms_since(t0);
  return ne;
}

}  // namespace kestrel::gpu
