// The scalar references of the alignment kernels (alignment_kernels.hpp): one point at a time,
// written for clarity. A Highway "-inl" header: alignment_kernels.cpp includes it once per SIMD
// target, and the public *_scalar functions run the copy compiled for the target the kernels run
// on; alignment_kernels_reference.cpp compiles it once more for the baseline target, the copy the
// kernels run on the points that do not fill a vector (alignment_kernels_reference.hpp says why).
// The source is the one reference; only its code generation follows the target, as a
// -march=native build's did: VEX encodings, and on AVX2 and AVX-512 the FMAs GCC contracts
// a * b + c into (its C++ default), which round once where the baseline build rounds twice; the
// tests' tolerances hold the kernels to the reference on every target either way.
//
// Private to the odometry module.

#include "alignment_kernels_reference.hpp"  // MedianBracket

// Per target: the guard toggles with HWY_TARGET_TOGGLE (Highway's -inl.h convention).
#if defined(KESTREL_ODOMETRY_ALIGNMENT_KERNELS_REFERENCE_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_ODOMETRY_ALIGNMENT_KERNELS_REFERENCE_INL_H_
#undef KESTREL_ODOMETRY_ALIGNMENT_KERNELS_REFERENCE_INL_H_
#else
#define KESTREL_ODOMETRY_ALIGNMENT_KERNELS_REFERENCE_INL_H_
#endif

#include <hwy/highway.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "kestrel/image/interpolation.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace kestrel::odometry::kernels::HWY_NAMESPACE::reference {

// Catmull-Rom weights of the 4 taps at offsets -1, 0, 1, 2 for a fractional position t.
inline void catmull_rom_weights(float t, float w[4]) {
  const float t2 = t * t, t3 = t2 * t;
  w[0] = 0.5F * (-t + 2.0F * t2 - t3);
  w[1] = 0.5F * (2.0F - 5.0F * t2 + 3.0F * t3);
  w[2] = 0.5F * (t + 4.0F * t2 - 3.0F * t3);
  w[3] = 0.5F * (t3 - t2);
}

// Bicubic sample at (u, v) in [0, w-1) x [0, h-1); bilinear within a pixel of the border.
inline float sample_bicubic(const LevelImage& cur, float u, float v) {
  const int x0 = static_cast<int>(u);
  const int y0 = static_cast<int>(v);
  if (x0 < 1 || y0 < 1 || x0 > cur.width - 3 || y0 > cur.height - 3) {
    return image::sample_bilinear_unchecked(cur.data, cur.stride, u, v);
  }
  float wx[4], wy[4];
  catmull_rom_weights(u - static_cast<float>(x0), wx);
  catmull_rom_weights(v - static_cast<float>(y0), wy);
  float out = 0.0F;
  for (int k = 0; k < 4; ++k) {
    const float* r = cur.data + static_cast<std::ptrdiff_t>(y0 - 1 + k) * cur.stride + (x0 - 1);
    out += wy[k] * (wx[0] * r[0] + wx[1] * r[1] + wx[2] * r[2] + wx[3] * r[3]);
  }
  return out;
}

// One point of warp_residuals; returns whether it is valid.
inline bool warp_point(const PointsView& p, const LevelImage& cur, const FloatPose& T, float umax,
                       float vmax, float alpha, float beta, int i, Sampling sampling,
                       float& residual) {
  const float X = T.r00 * p.x[i] + T.r01 * p.y[i] + T.r02 * p.z[i] + T.t0;
  const float Y = T.r10 * p.x[i] + T.r11 * p.y[i] + T.r12 * p.z[i] + T.t1;
  const float Z = T.r20 * p.x[i] + T.r21 * p.y[i] + T.r22 * p.z[i] + T.t2;
  const float inv_z = 1.0F / Z;
  float u = cur.fx * X * inv_z + cur.cx;
  float v = cur.fy * Y * inv_z + cur.cy;
  // NaN-safe: every comparison with NaN is false.
  const bool inside = Z > 1e-3F && u >= 0.0F && u < umax && v >= 0.0F && v < vmax;
  u = inside ? u : 0.0F;
  v = inside ? v : 0.0F;
  const float ic = sampling == Sampling::kBicubic
                       ? sample_bicubic(cur, u, v)
                       : image::sample_bilinear_unchecked(cur.data, cur.stride, u, v);
  residual = inside ? alpha * ic + beta - p.intensity[i] : 0.0F;
  return inside;
}

// Tukey cost (thesis eq. 3.39 integrated) and weight of s = u / c.
struct Tukey {
  float k;  // c^2 / 6 = rho_max
  float cost(float s2) const {
    const float t = 1.0F - s2;
    return s2 <= 1.0F ? k * (1.0F - t * t * t) : k;
  }
  static float weight(float s2) {
    const float t = 1.0F - s2;
    return s2 <= 1.0F ? t * t : 0.0F;
  }
};

// Points [begin, count) of warp_residuals; returns how many are valid.
inline int warp_range(const PointsView& p, const LevelImage& cur, const FloatPose& T, float alpha,
                      float beta, int begin, float* residual, std::uint8_t* valid,
                      Sampling sampling) {
  const auto umax = static_cast<float>(cur.width - 1);
  const auto vmax = static_cast<float>(cur.height - 1);
  int inside_count = 0;
  for (int i = begin; i < p.count; ++i) {
    const bool inside = warp_point(p, cur, T, umax, vmax, alpha, beta, i, sampling, residual[i]);
    valid[i] = inside ? 1 : 0;
    inside_count += inside ? 1 : 0;
  }
  return inside_count;
}

// Points [first, count) of warp_point_to_plane, one at a time. Without early exits (a point
// without a normal or a usable sample gets zero residual, Jacobian and validity): the loop
// without branches out of it is the faster one (docs/odometry.md, "Speed").
inline int point_to_plane_range(const PlanePointsView& p, const LevelImage& dep, const FloatPose& T,
                                float max_spread, int first, float* res, std::uint8_t* val,
                                float* const* jac) {
  const auto [r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2] = T;
  const float fx = dep.fx, fy = dep.fy, cx = dep.cx, cy = dep.cy;
  const float inv_fx = 1.0F / fx, inv_fy = 1.0F / fy;
  const auto umax = static_cast<float>(dep.width - 1);
  const auto vmax = static_cast<float>(dep.height - 1);
  const float* data = dep.data;
  const int stride = dep.stride;
  const float spread = 1.0F + max_spread;
  int count = 0;
  for (int i = first; i < p.count; ++i) {
    const float X = r00 * p.x[i] + r01 * p.y[i] + r02 * p.z[i] + t0;
    const float Y = r10 * p.x[i] + r11 * p.y[i] + r12 * p.z[i] + t1;
    const float Z = r20 * p.x[i] + r21 * p.y[i] + r22 * p.z[i] + t2;
    const float inv_z = 1.0F / Z;
    float u = fx * X * inv_z + cx;
    float v = fy * Y * inv_z + cy;
    // NaN-safe: every comparison with NaN is false. Bitwise & (no short circuit): no branches.
    const bool inside =
        (p.has_normal[i] != 0) & (Z > 1e-3F) & (u >= 0.0F) & (u < umax) & (v >= 0.0F) & (v < vmax);
    u = inside ? u : 0.0F;
    v = inside ? v : 0.0F;
    const int u0 = static_cast<int>(u);
    const int v0 = static_cast<int>(v);
    const float* d = data + v0 * stride + u0;
    const float z00 = d[0], z01 = d[1], z10 = d[stride], z11 = d[stride + 1];
    const bool depths = (z00 > 0.0F) & (z01 > 0.0F) & (z10 > 0.0F) & (z11 > 0.0F) & (z00 < 1e3F) &
                        (z01 < 1e3F) & (z10 < 1e3F) & (z11 < 1e3F);
    const float zmin = std::min(std::min(z00, z01), std::min(z10, z11));
    const float zmax = std::max(std::max(z00, z01), std::max(z10, z11));
    // Interpolated only within one surface (no occlusion boundary in the 2x2 cell).
    const bool ok = inside & depths & (zmax <= spread * zmin);
    const float a = u - static_cast<float>(u0);
    const float b = v - static_cast<float>(v0);
    const float z = (1.0F - b) * ((1.0F - a) * z00 + a * z01) + b * ((1.0F - a) * z10 + a * z11);
    // Q_cur back-projected at (u, v); into the reference frame: R^T (Q_cur - t).
    const float dx = (u - cx) * inv_fx * z - t0;
    const float dy = (v - cy) * inv_fy * z - t1;
    const float dz = z - t2;
    const float qx = r00 * dx + r10 * dy + r20 * dz;
    const float qy = r01 * dx + r11 * dy + r21 * dz;
    const float qz = r02 * dx + r12 * dy + r22 * dz;
    const float nx = p.nx[i], ny = p.ny[i], nz = p.nz[i];
    res[i] = ok ? nx * qx + ny * qy + nz * qz - p.n_dot_p[i] : 0.0F;
    jac[0][i] = ok ? -nx : 0.0F;
    jac[1][i] = ok ? -ny : 0.0F;
    jac[2][i] = ok ? -nz : 0.0F;
    jac[3][i] = ok ? -(qy * nz - qz * ny) : 0.0F;
    jac[4][i] = ok ? -(qz * nx - qx * nz) : 0.0F;
    jac[5][i] = ok ? -(qx * ny - qy * nx) : 0.0F;
    val[i] = ok ? 1 : 0;
    count += ok ? 1 : 0;
  }
  return count;
}

// Points [begin, count) of tukey_cost_sum.
inline double tukey_cost_range(const float* residual, const std::uint8_t* valid, int begin,
                               int count, float inv_sigma, float c) {
  const Tukey tk{c * c / 6.0F};
  const float inv_sc = inv_sigma / c;
  double cost = 0.0;
  for (int i = begin; i < count; ++i) {
    const float s = residual[i] * inv_sc;
    cost += static_cast<double>(valid[i] ? tk.cost(s * s) : tk.k);
  }
  return cost;
}

// Points [begin, count) of tukey_weights.
inline WeightSums tukey_weights_range(const float* residual, const std::uint8_t* valid, int begin,
                                      int count, float inv_sigma, float c, float* weight) {
  const Tukey tk{c * c / 6.0F};
  const float inv_sc = inv_sigma / c;
  const float inv_sigma2 = inv_sigma * inv_sigma;
  WeightSums out;
  for (int i = begin; i < count; ++i) {
    const float s = residual[i] * inv_sc;
    const float s2 = s * s;
    const bool ok = valid[i] != 0;
    weight[i] = ok ? Tukey::weight(s2) * inv_sigma2 : 0.0F;
    out.cost += static_cast<double>(ok ? tk.cost(s2) : tk.k);
    out.inliers += (ok && s2 < 1.0F) ? 1 : 0;
  }
  return out;
}

// gather_abs_valid: |r| of the valid points, packed.
inline int gather_abs_valid(const float* residual, const std::uint8_t* valid, int count,
                            float* out) {
  int m = 0;
  for (int i = 0; i < count; ++i) {
    out[m] = std::fabs(residual[i]);
    m += valid[i];
  }
  return m;
}

// select_kth: the k-th smallest by the standard library's selection.
inline float select_kth(float* v, int n, int k) {
  std::nth_element(v, v + k, v + n);
  return v[k];
}

// Points [begin, count) of abs_median's bracket pass (MedianBracket above).
inline void bracket_range(const float* residual, const std::uint8_t* valid, int begin, int count,
                          float lo, float hi, MedianBracket& b, float* scratch) {
  for (int i = begin; i < count; ++i) {
    if (valid[i] == 0) continue;
    const float a = std::fabs(residual[i]);
    ++b.valid;
    if (a < lo) {
      ++b.below;
    } else if (a < hi) {
      scratch[b.inside++] = a;
    }
  }
}

// accumulate_normal_equations<C>, one point at a time in double. Needs no padding.
template <int C>
void accumulate_normal_equations(const float* const* J, int count, const float* w, const float* r,
                                 Matrix8d& H, Vector8d& g) {
  static_assert(C >= 1 && C <= 8);
  for (int i = 0; i < count; ++i) {
    for (int a = 0; a < C; ++a) {
      const double wa = static_cast<double>(w[i]) * static_cast<double>(J[a][i]);
      for (int b = a; b < C; ++b) H(a, b) += wa * static_cast<double>(J[b][i]);
      g(a) += wa * static_cast<double>(r[i]);
    }
  }
  for (int a = 0; a < C; ++a) {
    for (int b = 0; b < a; ++b) H(a, b) = H(b, a);
  }
}

}  // namespace kestrel::odometry::kernels::HWY_NAMESPACE::reference
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_ODOMETRY_ALIGNMENT_KERNELS_REFERENCE_INL_H_
