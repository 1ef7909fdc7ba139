// The per-iteration alignment kernels (alignment_kernels.hpp). The warp is written with AVX2
// gathers where the compiler targets them (GCC 12 does not vectorise the bilinear sample on its
// own: "control flow in loop"), and so are the Tukey loops (the same), accumulating their cost in
// double lanes. Without AVX2 every kernel runs its scalar loop.
#include "kestrel/odometry/alignment_kernels.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "kestrel/image/interpolation.hpp"

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define KESTREL_KERNELS_AVX2 1
#endif

namespace kestrel::odometry::kernels {

FloatPose FloatPose::from(const SE3& T) {
  const Eigen::Matrix3f R = T.rotation_matrix().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  return {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2),
          R(2, 0), R(2, 1), R(2, 2), t.x(),   t.y(),   t.z()};
}

namespace {

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

int warp_range_scalar(const PointsView& p, const LevelImage& cur, const FloatPose& T, float alpha,
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

#ifdef KESTREL_KERNELS_AVX2
// The 8 valid bytes for each movemask value.
constexpr std::array<std::uint64_t, 256> kMaskBytes = [] {
  std::array<std::uint64_t, 256> t{};
  for (unsigned m = 0; m < 256; ++m) {
    for (unsigned k = 0; k < 8; ++k) {
      if ((m >> k) & 1U) t[m] |= std::uint64_t{1} << (8 * k);
    }
  }
  return t;
}();

// 8 points moved by T_cur_ref and projected with a level's pinhole model, as both warps need
// them: `inside` = Z > 1 mm and (u, v) in [0, w-1) x [0, h-1) (ordered comparisons: false for
// NaN, as in the scalar loops); outside lanes are moved to pixel (0, 0), so that every gather
// stays in bounds. x0, y0 are the sample cell's corner and ax, ay the position within it.
struct Projected8 {
  __m256 u, v, inside, ax, ay;
  __m256i x0, y0;
};
// T_cur_ref broadcast to 8 lanes.
struct PoseLanes {
  __m256 r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2;
  explicit PoseLanes(const FloatPose& T)
      : r00(_mm256_set1_ps(T.r00)),
        r01(_mm256_set1_ps(T.r01)),
        r02(_mm256_set1_ps(T.r02)),
        r10(_mm256_set1_ps(T.r10)),
        r11(_mm256_set1_ps(T.r11)),
        r12(_mm256_set1_ps(T.r12)),
        r20(_mm256_set1_ps(T.r20)),
        r21(_mm256_set1_ps(T.r21)),
        r22(_mm256_set1_ps(T.r22)),
        t0(_mm256_set1_ps(T.t0)),
        t1(_mm256_set1_ps(T.t1)),
        t2(_mm256_set1_ps(T.t2)) {}
};

struct Projector8 {
  PoseLanes T;
  __m256 fx, fy, cx, cy, umax, vmax;

  Projector8(const FloatPose& pose, const LevelImage& level)
      : T(pose),
        fx(_mm256_set1_ps(level.fx)),
        fy(_mm256_set1_ps(level.fy)),
        cx(_mm256_set1_ps(level.cx)),
        cy(_mm256_set1_ps(level.cy)),
        umax(_mm256_set1_ps(static_cast<float>(level.width - 1))),
        vmax(_mm256_set1_ps(static_cast<float>(level.height - 1))) {}

  Projected8 operator()(const float* x, const float* y, const float* z) const {
    const __m256 px = _mm256_loadu_ps(x), py = _mm256_loadu_ps(y), pz = _mm256_loadu_ps(z);
    const __m256 X =
        _mm256_fmadd_ps(T.r00, px, _mm256_fmadd_ps(T.r01, py, _mm256_fmadd_ps(T.r02, pz, T.t0)));
    const __m256 Y =
        _mm256_fmadd_ps(T.r10, px, _mm256_fmadd_ps(T.r11, py, _mm256_fmadd_ps(T.r12, pz, T.t1)));
    const __m256 Z =
        _mm256_fmadd_ps(T.r20, px, _mm256_fmadd_ps(T.r21, py, _mm256_fmadd_ps(T.r22, pz, T.t2)));
    const __m256 inv_z = _mm256_div_ps(_mm256_set1_ps(1.0F), Z);
    Projected8 p;
    p.u = _mm256_fmadd_ps(_mm256_mul_ps(fx, X), inv_z, cx);
    p.v = _mm256_fmadd_ps(_mm256_mul_ps(fy, Y), inv_z, cy);
    const __m256 zero = _mm256_setzero_ps();
    __m256 m = _mm256_and_ps(_mm256_cmp_ps(Z, _mm256_set1_ps(1e-3F), _CMP_GT_OQ),
                             _mm256_cmp_ps(p.u, zero, _CMP_GE_OQ));
    m = _mm256_and_ps(m, _mm256_cmp_ps(p.u, umax, _CMP_LT_OQ));
    m = _mm256_and_ps(m, _mm256_cmp_ps(p.v, zero, _CMP_GE_OQ));
    m = _mm256_and_ps(m, _mm256_cmp_ps(p.v, vmax, _CMP_LT_OQ));
    p.inside = m;
    p.u = _mm256_and_ps(p.u, m);
    p.v = _mm256_and_ps(p.v, m);
    p.x0 = _mm256_cvttps_epi32(p.u);
    p.y0 = _mm256_cvttps_epi32(p.v);
    p.ax = _mm256_sub_ps(p.u, _mm256_cvtepi32_ps(p.x0));
    p.ay = _mm256_sub_ps(p.v, _mm256_cvtepi32_ps(p.y0));
    return p;
  }
};

// The 2x2 cell at (x0, y0) of 8 lanes: four gathers.
struct Cell8 {
  __m256 p00, p01, p10, p11;
};
inline Cell8 gather_cell(const LevelImage& img, __m256i x0, __m256i y0) {
  const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(y0, _mm256_set1_epi32(img.stride)), x0);
  return {_mm256_i32gather_ps(img.data, idx, 4), _mm256_i32gather_ps(img.data + 1, idx, 4),
          _mm256_i32gather_ps(img.data + img.stride, idx, 4),
          _mm256_i32gather_ps(img.data + img.stride + 1, idx, 4)};
}

// Catmull-Rom weights of 8 lanes (catmull_rom_weights).
inline void catmull_rom_weights8(__m256 t, __m256 w[4]) {
  const __m256 half = _mm256_set1_ps(0.5F);
  const __m256 t2 = _mm256_mul_ps(t, t), t3 = _mm256_mul_ps(t2, t);
  const __m256 two = _mm256_set1_ps(2.0F), three = _mm256_set1_ps(3.0F);
  w[0] = _mm256_mul_ps(half, _mm256_sub_ps(_mm256_fmsub_ps(two, t2, t), t3));
  w[1] = _mm256_mul_ps(half,
                       _mm256_fmadd_ps(three, t3, _mm256_fnmadd_ps(_mm256_set1_ps(5.0F), t2, two)));
  w[2] = _mm256_mul_ps(half,
                       _mm256_fnmadd_ps(three, t3, _mm256_fmadd_ps(_mm256_set1_ps(4.0F), t2, t)));
  w[3] = _mm256_mul_ps(half, _mm256_sub_ps(t3, t2));
}

// The bicubic sample of 8 lanes: 16 gathers from the clamped 4x4 neighbourhood. `interior`
// marks the lanes it holds for; the others (within a pixel of the border) take the bilinear
// sample, as sample_bicubic does.
inline __m256 bicubic_lanes(const LevelImage& cur, __m256i x0, __m256i y0, __m256 ax, __m256 ay,
                            __m256& interior) {
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i xmax = _mm256_set1_epi32(cur.width - 3), ymax = _mm256_set1_epi32(cur.height - 3);
  const __m256i inner = _mm256_and_si256(
      _mm256_and_si256(_mm256_cmpgt_epi32(x0, _mm256_setzero_si256()),
                       _mm256_cmpgt_epi32(y0, _mm256_setzero_si256())),
      _mm256_andnot_si256(
          _mm256_or_si256(_mm256_cmpgt_epi32(x0, xmax), _mm256_cmpgt_epi32(y0, ymax)),
          _mm256_set1_epi32(-1)));
  const __m256i xc = _mm256_max_epi32(one, _mm256_min_epi32(x0, xmax));
  const __m256i yc = _mm256_max_epi32(one, _mm256_min_epi32(y0, ymax));
  const __m256i stride = _mm256_set1_epi32(cur.stride);
  __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(yc, one), stride),
                                 _mm256_sub_epi32(xc, one));
  __m256 wx[4], wy[4];
  catmull_rom_weights8(ax, wx);
  catmull_rom_weights8(ay, wy);
  __m256 out = _mm256_setzero_ps();
  for (int k = 0; k < 4; ++k) {
    __m256 row = _mm256_mul_ps(wx[0], _mm256_i32gather_ps(cur.data, idx, 4));
    row = _mm256_fmadd_ps(wx[1], _mm256_i32gather_ps(cur.data + 1, idx, 4), row);
    row = _mm256_fmadd_ps(wx[2], _mm256_i32gather_ps(cur.data + 2, idx, 4), row);
    row = _mm256_fmadd_ps(wx[3], _mm256_i32gather_ps(cur.data + 3, idx, 4), row);
    out = _mm256_fmadd_ps(wy[k], row, out);
    idx = _mm256_add_epi32(idx, stride);
  }
  interior = _mm256_castsi256_ps(inner);
  return out;
}
#endif

}  // namespace

int warp_residuals_scalar(const PointsView& points, const LevelImage& cur,
                          const FloatPose& T_cur_ref, float alpha, float beta, float* residual,
                          std::uint8_t* valid, Sampling sampling) {
  return warp_range_scalar(points, cur, T_cur_ref, alpha, beta, 0, residual, valid, sampling);
}

int warp_residuals(const PointsView& points, const LevelImage& cur, const FloatPose& T_cur_ref,
                   float alpha, float beta, float* residual, std::uint8_t* valid,
                   Sampling sampling) {
#ifdef KESTREL_KERNELS_AVX2
  const bool bicubic = sampling == Sampling::kBicubic && cur.width >= 4 && cur.height >= 4;
  const Projector8 project(T_cur_ref, cur);
  const __m256 va = _mm256_set1_ps(alpha), vb = _mm256_set1_ps(beta);
  int inside_count = 0;
  int i = 0;
  for (; i + 8 <= points.count; i += 8) {
    const Projected8 p = project(points.x + i, points.y + i, points.z + i);
    const __m256 m = p.inside;
    const __m256i x0 = p.x0, y0 = p.y0;
    const __m256 ax = p.ax, ay = p.ay;
    auto bilinear = [&] {
      const auto [p00, p01, p10, p11] = gather_cell(cur, x0, y0);
      const __m256 top = _mm256_fmadd_ps(ax, _mm256_sub_ps(p01, p00), p00);
      const __m256 bottom = _mm256_fmadd_ps(ax, _mm256_sub_ps(p11, p10), p10);
      return _mm256_fmadd_ps(ay, _mm256_sub_ps(bottom, top), top);
    };
    __m256 ic;
    if (bicubic) {
      // The bilinear gathers only where a lane is within a pixel of the border.
      __m256 interior;
      ic = bicubic_lanes(cur, x0, y0, ax, ay, interior);
      if (_mm256_movemask_ps(interior) != 0xFF) ic = _mm256_blendv_ps(bilinear(), ic, interior);
    } else {
      ic = bilinear();
    }
    const __m256 r =
        _mm256_sub_ps(_mm256_fmadd_ps(va, ic, vb), _mm256_loadu_ps(points.intensity + i));
    _mm256_storeu_ps(residual + i, _mm256_and_ps(r, m));
    const auto mask = static_cast<unsigned>(_mm256_movemask_ps(m));
    std::memcpy(valid + i, &kMaskBytes[mask], 8);
    inside_count += std::popcount(mask);
  }
  return inside_count +
         warp_range_scalar(points, cur, T_cur_ref, alpha, beta, i, residual, valid, sampling);
#else
  return warp_residuals_scalar(points, cur, T_cur_ref, alpha, beta, residual, valid, sampling);
#endif
}

namespace {

// Points [first, count) of warp_point_to_plane, one at a time. Without early exits (a point
// without a normal or a usable sample gets zero residual, Jacobian and validity): the loop
// without branches out of it is the faster one (docs/odometry.md, "Speed").
int point_to_plane_range_scalar(const PlanePointsView& p, const LevelImage& dep, const FloatPose& T,
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

}  // namespace

int warp_point_to_plane_scalar(const PlanePointsView& points, const LevelImage& depth,
                               const FloatPose& T_cur_ref, float max_spread, float* residual,
                               std::uint8_t* valid, float* const* jac) {
  return point_to_plane_range_scalar(points, depth, T_cur_ref, max_spread, 0, residual, valid, jac);
}

// The same, 8 points per step: the four depth samples by AVX2 gathers, the masks as in
// warp_residuals (invalid lanes read pixel (0, 0) and are zeroed at the stores).
int warp_point_to_plane(const PlanePointsView& points, const LevelImage& depth,
                        const FloatPose& T_cur_ref, float max_spread, float* residual,
                        std::uint8_t* valid, float* const* jac) {
#ifdef KESTREL_KERNELS_AVX2
  const Projector8 project(T_cur_ref, depth);
  const auto& [r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2] = project.T;
  const __m256 cx = project.cx, cy = project.cy;
  const __m256 inv_fx = _mm256_set1_ps(1.0F / depth.fx), inv_fy = _mm256_set1_ps(1.0F / depth.fy);
  const __m256 zero = _mm256_setzero_ps(), far = _mm256_set1_ps(1e3F);
  const __m256 spread = _mm256_set1_ps(1.0F + max_spread);
  int count = 0;
  int i = 0;
  for (; i + 8 <= points.count; i += 8) {
    const Projected8 p = project(points.x + i, points.y + i, points.z + i);
    std::uint64_t has_bytes = 0;
    std::memcpy(&has_bytes, points.has_normal + i, 8);
    const __m256i has = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(has_bytes)));
    __m256 m = _mm256_and_ps(p.inside,
                             _mm256_castsi256_ps(_mm256_cmpgt_epi32(has, _mm256_setzero_si256())));
    const __m256 u = p.u, v = p.v;
    const __m256i x0 = p.x0, y0 = p.y0;
    const auto [z00, z01, z10, z11] = gather_cell(depth, x0, y0);
    auto in_range = [&](__m256 zz) {
      return _mm256_and_ps(_mm256_cmp_ps(zz, zero, _CMP_GT_OQ), _mm256_cmp_ps(zz, far, _CMP_LT_OQ));
    };
    m = _mm256_and_ps(m, _mm256_and_ps(_mm256_and_ps(in_range(z00), in_range(z01)),
                                       _mm256_and_ps(in_range(z10), in_range(z11))));
    const __m256 zlo = _mm256_min_ps(_mm256_min_ps(z00, z01), _mm256_min_ps(z10, z11));
    const __m256 zhi = _mm256_max_ps(_mm256_max_ps(z00, z01), _mm256_max_ps(z10, z11));
    m = _mm256_and_ps(m, _mm256_cmp_ps(zhi, _mm256_mul_ps(spread, zlo), _CMP_LE_OQ));
    const __m256 a = p.ax, b = p.ay;
    const __m256 top = _mm256_fmadd_ps(a, _mm256_sub_ps(z01, z00), z00);
    const __m256 bottom = _mm256_fmadd_ps(a, _mm256_sub_ps(z11, z10), z10);
    const __m256 z = _mm256_fmadd_ps(b, _mm256_sub_ps(bottom, top), top);
    const __m256 dx = _mm256_fmsub_ps(_mm256_mul_ps(_mm256_sub_ps(u, cx), inv_fx), z, t0);
    const __m256 dy = _mm256_fmsub_ps(_mm256_mul_ps(_mm256_sub_ps(v, cy), inv_fy), z, t1);
    const __m256 dz = _mm256_sub_ps(z, t2);
    const __m256 qx = _mm256_fmadd_ps(r00, dx, _mm256_fmadd_ps(r10, dy, _mm256_mul_ps(r20, dz)));
    const __m256 qy = _mm256_fmadd_ps(r01, dx, _mm256_fmadd_ps(r11, dy, _mm256_mul_ps(r21, dz)));
    const __m256 qz = _mm256_fmadd_ps(r02, dx, _mm256_fmadd_ps(r12, dy, _mm256_mul_ps(r22, dz)));
    const __m256 nx = _mm256_loadu_ps(points.nx + i);
    const __m256 ny = _mm256_loadu_ps(points.ny + i);
    const __m256 nz = _mm256_loadu_ps(points.nz + i);
    const __m256 r =
        _mm256_sub_ps(_mm256_fmadd_ps(nx, qx, _mm256_fmadd_ps(ny, qy, _mm256_mul_ps(nz, qz))),
                      _mm256_loadu_ps(points.n_dot_p + i));
    _mm256_storeu_ps(residual + i, _mm256_and_ps(r, m));
    const __m256 neg = _mm256_set1_ps(-0.0F);
    _mm256_storeu_ps(jac[0] + i, _mm256_and_ps(_mm256_xor_ps(nx, neg), m));
    _mm256_storeu_ps(jac[1] + i, _mm256_and_ps(_mm256_xor_ps(ny, neg), m));
    _mm256_storeu_ps(jac[2] + i, _mm256_and_ps(_mm256_xor_ps(nz, neg), m));
    _mm256_storeu_ps(jac[3] + i, _mm256_and_ps(_mm256_fmsub_ps(qz, ny, _mm256_mul_ps(qy, nz)), m));
    _mm256_storeu_ps(jac[4] + i, _mm256_and_ps(_mm256_fmsub_ps(qx, nz, _mm256_mul_ps(qz, nx)), m));
    _mm256_storeu_ps(jac[5] + i, _mm256_and_ps(_mm256_fmsub_ps(qy, nx, _mm256_mul_ps(qx, ny)), m));
    const auto mask = static_cast<unsigned>(_mm256_movemask_ps(m));
    std::memcpy(valid + i, &kMaskBytes[mask], 8);
    count += std::popcount(mask);
  }
  return count +
         point_to_plane_range_scalar(points, depth, T_cur_ref, max_spread, i, residual, valid, jac);
#else
  return warp_point_to_plane_scalar(points, depth, T_cur_ref, max_spread, residual, valid, jac);
#endif
}

namespace {

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

}  // namespace

#ifdef KESTREL_KERNELS_AVX2
namespace {

// 8 valid bytes as a float mask (all ones where valid).
inline __m256 valid_mask(const std::uint8_t* valid) {
  std::int64_t bytes = 0;
  std::memcpy(&bytes, valid, 8);
  const __m256i v = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(bytes));
  return _mm256_castsi256_ps(_mm256_cmpgt_epi32(v, _mm256_setzero_si256()));
}

// Tukey cost of s^2 (rho_max beyond c) and weight (0 beyond c), 8 lanes; `in` = s^2 <= 1.
struct TukeyLanes {
  __m256 k, one;
  __m256 cost(__m256 s2, __m256 in) const {
    const __m256 t = _mm256_sub_ps(one, s2);
    const __m256 t3 = _mm256_mul_ps(_mm256_mul_ps(t, t), t);
    return _mm256_blendv_ps(k, _mm256_mul_ps(k, _mm256_sub_ps(one, t3)), in);
  }
  __m256 weight(__m256 s2, __m256 in) const {
    const __m256 t = _mm256_sub_ps(one, s2);
    return _mm256_and_ps(_mm256_mul_ps(t, t), in);
  }
};

inline __m256d add_as_double(__m256d acc, __m256 x) {
  acc = _mm256_add_pd(acc, _mm256_cvtps_pd(_mm256_castps256_ps128(x)));
  return _mm256_add_pd(acc, _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)));
}

inline double sum_lanes(__m256d acc) {
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, acc);
  return (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
}

}  // namespace
#endif

double tukey_cost_sum(const float* residual, const std::uint8_t* valid, int count, float inv_sigma,
                      float c) {
  const Tukey tk{c * c / 6.0F};
  const float inv_sc = inv_sigma / c;
  double cost = 0.0;
  int i = 0;
#ifdef KESTREL_KERNELS_AVX2
  const TukeyLanes lanes{_mm256_set1_ps(tk.k), _mm256_set1_ps(1.0F)};
  const __m256 scale = _mm256_set1_ps(inv_sc);
  __m256d acc = _mm256_setzero_pd();
  for (; i + 8 <= count; i += 8) {
    const __m256 s = _mm256_mul_ps(_mm256_loadu_ps(residual + i), scale);
    const __m256 s2 = _mm256_mul_ps(s, s);
    const __m256 in = _mm256_cmp_ps(s2, lanes.one, _CMP_LE_OQ);
    // Invalid points cost rho_max.
    const __m256 rho = _mm256_blendv_ps(lanes.k, lanes.cost(s2, in), valid_mask(valid + i));
    acc = add_as_double(acc, rho);
  }
  cost = sum_lanes(acc);
#endif
  for (; i < count; ++i) {
    const float s = residual[i] * inv_sc;
    cost += static_cast<double>(valid[i] ? tk.cost(s * s) : tk.k);
  }
  return cost;
}

WeightSums tukey_weights(const float* residual, const std::uint8_t* valid, int count,
                         float inv_sigma, float c, float* weight) {
  const Tukey tk{c * c / 6.0F};
  const float inv_sc = inv_sigma / c;
  const float inv_sigma2 = inv_sigma * inv_sigma;
  WeightSums out;
  int i = 0;
#ifdef KESTREL_KERNELS_AVX2
  const TukeyLanes lanes{_mm256_set1_ps(tk.k), _mm256_set1_ps(1.0F)};
  const __m256 scale = _mm256_set1_ps(inv_sc);
  const __m256 w_scale = _mm256_set1_ps(inv_sigma2);
  __m256d acc = _mm256_setzero_pd();
  for (; i + 8 <= count; i += 8) {
    const __m256 s = _mm256_mul_ps(_mm256_loadu_ps(residual + i), scale);
    const __m256 s2 = _mm256_mul_ps(s, s);
    const __m256 ok = valid_mask(valid + i);
    const __m256 in = _mm256_cmp_ps(s2, lanes.one, _CMP_LE_OQ);
    _mm256_storeu_ps(weight + i, _mm256_and_ps(_mm256_mul_ps(lanes.weight(s2, in), w_scale), ok));
    acc = add_as_double(acc, _mm256_blendv_ps(lanes.k, lanes.cost(s2, in), ok));
    const __m256 inlier = _mm256_and_ps(ok, _mm256_cmp_ps(s2, lanes.one, _CMP_LT_OQ));
    out.inliers += std::popcount(static_cast<unsigned>(_mm256_movemask_ps(inlier)));
  }
  out.cost = sum_lanes(acc);
#endif
  for (; i < count; ++i) {
    const float s = residual[i] * inv_sc;
    const float s2 = s * s;
    const bool ok = valid[i] != 0;
    weight[i] = ok ? Tukey::weight(s2) * inv_sigma2 : 0.0F;
    out.cost += static_cast<double>(ok ? tk.cost(s2) : tk.k);
    out.inliers += (ok && s2 < 1.0F) ? 1 : 0;
  }
  return out;
}

int gather_abs_valid(const float* residual, const std::uint8_t* valid, int count, float* out) {
  int m = 0;
  for (int i = 0; i < count; ++i) {
    out[m] = std::fabs(residual[i]);
    m += valid[i];
  }
  return m;
}

namespace {

// The element at index k of the n values in v (partially reorders v).
inline float select_kth(float* v, int n, int k) {
  std::nth_element(v, v + k, v + n);
  return v[k];
}

}  // namespace

AbsMedian abs_median(const float* residual, const std::uint8_t* valid, int count, float hint,
                     float* scratch) {
  AbsMedian out;
  if (hint > 0.0F && std::isfinite(hint)) {
    // Half-width 1/8 of the hint: near the optimum sigma moves by far less between iterations,
    // and a bracket this narrow holds ~11 % of Gaussian residuals, so the selection is on a few
    // hundred values instead of thousands.
    const float lo = hint * 0.875F;
    const float hi = hint * 1.125F;
    int below = 0, inside = 0, m = 0, i = 0;
#ifdef KESTREL_KERNELS_AVX2
    const __m256 sign = _mm256_set1_ps(-0.0F);
    const __m256 vlo = _mm256_set1_ps(lo), vhi = _mm256_set1_ps(hi);
    for (; i + 8 <= count; i += 8) {
      const __m256 a = _mm256_andnot_ps(sign, _mm256_loadu_ps(residual + i));
      const __m256 ok = valid_mask(valid + i);
      const auto okbits = static_cast<unsigned>(_mm256_movemask_ps(ok));
      const auto lt = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(a, vlo, _CMP_LT_OQ)));
      const auto in = static_cast<unsigned>(_mm256_movemask_ps(
          _mm256_and_ps(_mm256_cmp_ps(a, vlo, _CMP_GE_OQ), _mm256_cmp_ps(a, vhi, _CMP_LT_OQ))));
      m += std::popcount(okbits);
      below += std::popcount(okbits & lt);
      for (unsigned bits = okbits & in; bits != 0; bits &= bits - 1) {
        scratch[inside++] = std::fabs(residual[i + std::countr_zero(bits)]);
      }
    }
#endif
    for (; i < count; ++i) {
      if (valid[i] == 0) continue;
      const float a = std::fabs(residual[i]);
      ++m;
      if (a < lo) {
        ++below;
      } else if (a < hi) {
        scratch[inside++] = a;
      }
    }
    out.valid = m;
    if (m == 0) return out;
    const int k = m / 2;
    if (k >= below && k < below + inside) {
      out.median = select_kth(scratch, inside, k - below);
      return out;
    }
  }
  const int m = gather_abs_valid(residual, valid, count, scratch);
  out.valid = m;
  if (m > 0) out.median = select_kth(scratch, m, m / 2);
  return out;
}

}  // namespace kestrel::odometry::kernels
