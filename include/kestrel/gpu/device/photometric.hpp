// One Gauss-Newton iteration of the direct tracker per reference point, as the CUDA kernels run
// it (src/gpu/cuda/photometric_kernels.cu) and the CPU tests emulate it: the warp, bilinear
// sample and residual of DirectTracker's warp_residuals, the Tukey weights of thesis eq. 3.39
// (odometry/robust_weights.hpp) and the terms of the 8x8 normal equations (warp_jacobian.hpp).
#pragma once

#include "kestrel/gpu/device/hd.hpp"

namespace kestrel::gpu::device {

/// T_cur_ref (row-major R, t) and the level's camera and current image.
struct WarpParams {
  float r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  float t[3] = {0, 0, 0};
  float fx = 1, fy = 1, cx = 0, cy = 0;
  int width = 0, height = 0, stride = 0;  ///< current image
  float alpha = 1, beta = 0;              ///< gain and bias applied to the current image
};

/// The reference points of one level (structure of arrays, as odometry::ReferenceLevel).
struct PointsView {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const float* intensity = nullptr;
  const float* jac[8] = {};
  int count = 0;
};

/// Bilinear sample, pixel centres at integers; 0 <= x < w - 1, 0 <= y < h - 1 (unchecked):
/// image::sample_bilinear_unchecked.
KESTREL_HD float sample_bilinear(const float* data, int stride, float x, float y) {
  const int x0 = static_cast<int>(x);
  const int y0 = static_cast<int>(y);
  const float ax = x - static_cast<float>(x0);
  const float ay = y - static_cast<float>(y0);
  const float* p = data + static_cast<std::ptrdiff_t>(y0) * stride + x0;
  const float top = p[0] + ax * (p[1] - p[0]);
  const float bottom = p[stride] + ax * (p[stride + 1] - p[stride]);
  return top + ay * (bottom - top);
}

/// Warps reference point (px, py, pz) into the current image and returns whether it lands
/// inside; `residual` = alpha I_cur(u, v) + beta - i_ref there, else 0 (NaN-safe: a NaN
/// position compares false and counts as outside).
KESTREL_HD bool warp_residual(const WarpParams& p, const float* image, float px, float py, float pz,
                              float i_ref, float& residual) {
  const float* r = p.r;
  const float X = r[0] * px + r[1] * py + r[2] * pz + p.t[0];
  const float Y = r[3] * px + r[4] * py + r[5] * pz + p.t[1];
  const float Z = r[6] * px + r[7] * py + r[8] * pz + p.t[2];
  const float inv_z = 1.0F / Z;
  float u = p.fx * X * inv_z + p.cx;
  float v = p.fy * Y * inv_z + p.cy;
  const auto umax = static_cast<float>(p.width - 1);
  const auto vmax = static_cast<float>(p.height - 1);
  const bool inside = Z > 1e-3F && u >= 0.0F && u < umax && v >= 0.0F && v < vmax;
  u = inside ? u : 0.0F;
  v = inside ? v : 0.0F;
  const float ic = sample_bilinear(image, p.stride, u, v);
  residual = inside ? p.alpha * ic + p.beta - i_ref : 0.0F;
  return inside;
}

/// Tukey bi-weight w(u) = (1 - (u/c)^2)^2 for |u| <= c, else 0 (odometry::tukey_weight).
KESTREL_HD float tukey_weight(float u, float c) {
  const float s = u / c;
  const float t = 1.0F - s * s;
  return (s * s <= 1.0F) ? t * t : 0.0F;
}

/// Tukey cost c^2/6 (1 - (1 - (u/c)^2)^3) for |u| <= c, else c^2/6 (odometry::tukey_cost).
KESTREL_HD float tukey_cost(float u, float c) {
  const float s = u / c;
  const float t = 1.0F - s * s;
  const float k = c * c / 6.0F;
  return (s * s <= 1.0F) ? k * (1.0F - t * t * t) : k;
}

/// Accumulator layout: the 36 upper-triangle entries of H = sum w J J^T (row by row), the 8 of
/// g = sum w J r, the robust cost and the inlier count.
inline constexpr int kNormalTerms = 36 + 8 + 2;
inline constexpr int kCostTerm = 44;
inline constexpr int kInlierTerm = 45;

/// The reduction's launch shape: threads per block, and blocks for `count` points (each block
/// writes one partial of kNormalTerms sums; the host adds them in double, in block order).
inline constexpr int kNormalThreads = 256;
inline constexpr int kNormalMaxBlocks = 256;
KESTREL_HD int normal_equation_blocks(int count) {
  const int blocks = (count + kNormalThreads - 1) / kNormalThreads;
  return blocks < 1 ? 1 : (blocks > kNormalMaxBlocks ? kNormalMaxBlocks : blocks);
}

/// Adds one point's terms with w = tukey(r / sigma) / sigma^2 (0 when not valid); a point
/// that is not valid costs the maximum c^2/6, as outside the image in the tracker.
KESTREL_HD void accumulate_point(const float* jac, float r, bool valid, float inv_sigma, float c,
                                 float* acc) {
  const float u = r * inv_sigma;
  const float inv_sigma2 = inv_sigma * inv_sigma;
  const float w = valid ? tukey_weight(u, c) * inv_sigma2 : 0.0F;
  acc[kCostTerm] += valid ? tukey_cost(u, c) : c * c / 6.0F;
  acc[kInlierTerm] += (valid && fabsf(u) < c) ? 1.0F : 0.0F;
  int term = 0;
  KESTREL_UNROLL
  for (int a = 0; a < 8; ++a) {
    const float wj = w * jac[a];
    KESTREL_UNROLL
    for (int b = a; b < 8; ++b, ++term) acc[term] += wj * jac[b];
    acc[36 + a] += wj * r;
  }
}

}  // namespace kestrel::gpu::device
