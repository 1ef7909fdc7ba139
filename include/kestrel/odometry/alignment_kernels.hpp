// The per-iteration kernels of the direct alignment (thesis 3.5-3.10) on structure-of-arrays
// point data: warp + bilinear sample + photometric residual, Tukey cost and weights, and the
// weighted normal equations. DirectTracker calls them once per Gauss-Newton iteration; they are
// free functions on plain arrays so that each can be tested and benchmarked alone.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <type_traits>
#include <utility>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

#include "kestrel/geometry/se3.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"  // Matrix8d, Vector8d

namespace kestrel::odometry::kernels {

/// Accumulation lanes of the vectorised loops (one AVX register of floats). Per-point arrays
/// handed to accumulate_normal_equations are padded to a multiple of it, with zero weights.
inline constexpr int kLanes = 8;
inline int pad_to_lanes(int n) { return (n + kLanes - 1) / kLanes * kLanes; }

/// T_cur_ref in floats, unrolled (scalars the loops keep in registers).
struct FloatPose {
  float r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2;
  static FloatPose from(const SE3& T);
};

/// Reference points of one pyramid level: 3-D position in the reference camera and intensity.
struct PointsView {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const float* intensity = nullptr;
  int count = 0;
};

/// A CV_32FC1 image (row stride in floats) and the pinhole model of its level.
struct LevelImage {
  const float* data = nullptr;
  int stride = 0, width = 0, height = 0;
  float fx = 0, fy = 0, cx = 0, cy = 0;
};

/// How the current image is sampled at a warped point (image::Interpolation). With bilinear the
/// cost has a kink exactly where a still camera's points land; bicubic (Catmull-Rom, 4x4 taps)
/// has none. Within one pixel of the border bicubic falls back to bilinear.
using Sampling = image::Interpolation;

/// r_i = alpha I_cur(pi(T_cur_ref P_i)) + beta - I_ref,i for every point whose projection lies in
/// [0, w-1) x [0, h-1) with Z > 1 mm (valid_i = 1); elsewhere r_i = 0, valid_i = 0. Returns the
/// number of valid points. NaN coordinates are invalid. Uses AVX2 gathers where compiled for
/// them, else warp_residuals_scalar.
int warp_residuals(const PointsView& points, const LevelImage& cur, const FloatPose& T_cur_ref,
                   float alpha, float beta, float* residual, std::uint8_t* valid,
                   Sampling sampling = Sampling::kBilinear);
/// The reference implementation (one point at a time); results equal warp_residuals' to float
/// rounding.
int warp_residuals_scalar(const PointsView& points, const LevelImage& cur,
                          const FloatPose& T_cur_ref, float alpha, float beta, float* residual,
                          std::uint8_t* valid, Sampling sampling = Sampling::kBilinear);

/// Reference points with a unit normal for the point-to-plane residual: has_normal = 0 where
/// the reference depth gives none (those points take no part).
struct PlanePointsView {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const float* nx = nullptr;
  const float* ny = nullptr;
  const float* nz = nullptr;
  const float* n_dot_p = nullptr;
  const std::uint8_t* has_normal = nullptr;
  int count = 0;
};

/// The point-to-plane residual r_g,i = n_i . R^T (Q_i - t) - n_i . P_i, Q_i the current depth
/// map `depth` (metres, its level's pinhole model) back-projected at pi(T_cur_ref P_i) and
/// bilinearly interpolated, and its pose Jacobian J_g,i = -[n_i, (R^T (Q_i - t)) x n_i]
/// (point_to_plane_pose_jacobian) into jac[0..5], for every point with a normal whose
/// projection lies in [0, w-1) x [0, h-1) with Z > 1 mm and whose 2x2 depth cell is one surface
/// (every depth in (0, 1e3), the farthest within (1 + max_spread) of the nearest): valid_i = 1.
/// Elsewhere r, J and valid are 0. Returns the number of valid points. Uses AVX2 gathers where
/// compiled for them, else warp_point_to_plane_scalar.
int warp_point_to_plane(const PlanePointsView& points, const LevelImage& depth,
                        const FloatPose& T_cur_ref, float max_spread, float* residual,
                        std::uint8_t* valid, float* const* jac);
/// The reference implementation (one point at a time); results equal warp_point_to_plane's to
/// float rounding.
int warp_point_to_plane_scalar(const PlanePointsView& points, const LevelImage& depth,
                               const FloatPose& T_cur_ref, float max_spread, float* residual,
                               std::uint8_t* valid, float* const* jac);

/// sum_i rho(r_i / sigma) over valid points plus rho_max = c^2/6 per invalid point (Tukey cost,
/// thesis eq. 3.39 integrated): the robust cost a step is accepted on.
double tukey_cost_sum(const float* residual, const std::uint8_t* valid, int count, float inv_sigma,
                      float c);

struct WeightSums {
  double cost = 0.0;  ///< as tukey_cost_sum
  int inliers = 0;    ///< valid points with |r / sigma| < c
};
/// w_i = w(r_i / sigma) / sigma^2 (Tukey weight, thesis eq. 3.39, carrying 1/sigma^2 so that
/// H^-1 is the covariance); 0 for invalid points. Returns the cost and inlier count as well.
WeightSums tukey_weights(const float* residual, const std::uint8_t* valid, int count,
                         float inv_sigma, float c, float* weight);

/// Writes |r_i| of the valid points, packed, to `out`; returns how many (the input of
/// robust_sigma, thesis eq. 3.40).
int gather_abs_valid(const float* residual, const std::uint8_t* valid, int count, float* out);

struct AbsMedian {
  float median = 0.0F;  ///< the element at m / 2 of the valid points' sorted |r| (0 if m = 0)
  int valid = 0;        ///< m, the number of valid points
};
/// The upper median of |r_i| over the valid points, what robust_sigma selects (thesis eq. 3.40),
/// found near `hint` (> 0: a guess of it, e.g. the last iteration's median; <= 0: none). One pass
/// counts the valid points below a bracket around the hint and packs the few inside it into
/// `scratch` (room for `count`), and the selection runs on those alone; where the median is not
/// in the bracket all |r| are packed and selected, as gather_abs_valid + robust_sigma do. The
/// result is the same element either way; the hint only saves the O(m) selection over all
/// points, which the Gauss-Newton loop would otherwise run every iteration (its sigma changes
/// little once the level is near its optimum).
AbsMedian abs_median(const float* residual, const std::uint8_t* valid, int count, float hint,
                     float* scratch);

#if defined(__AVX2__) && defined(__FMA__)
namespace detail {

// Row A of the normal equations: sum w J_A J_b for b = A..C-1 and sum w J_A r, each in one AVX
// accumulator (C - A + 1 <= 9 of them: they stay in registers, unlike the 44 lane arrays of all
// rows at once, which spill to memory; docs/odometry.md, "Speed").
template <int A, int C>
void accumulate_row(const float* const* J, int n, const float* w, const float* r, double* row) {
  constexpr int kTerms = C - A + 1;
  static_assert(kLanes == 8);
  const float* ja = J[A];
  __m256 acc[kTerms];
#pragma GCC unroll 16
  for (int t = 0; t < kTerms; ++t) acc[t] = _mm256_setzero_ps();
  for (int i = 0; i < n; i += kLanes) {
    const __m256 wa = _mm256_mul_ps(_mm256_loadu_ps(w + i), _mm256_loadu_ps(ja + i));
#pragma GCC unroll 16
    for (int b = A; b < C; ++b) {
      acc[b - A] = _mm256_fmadd_ps(wa, _mm256_loadu_ps(J[b] + i), acc[b - A]);
    }
    acc[kTerms - 1] = _mm256_fmadd_ps(wa, _mm256_loadu_ps(r + i), acc[kTerms - 1]);
  }
  for (int t = 0; t < kTerms; ++t) {
    alignas(32) float lanes[kLanes];
    _mm256_store_ps(lanes, acc[t]);
    double s = 0.0;
    for (float x : lanes) s += static_cast<double>(x);
    row[t] = s;
  }
}

template <int C, int... A>
void accumulate_rows(const float* const* J, int n, const float* w, const float* r, Matrix8d& H,
                     Vector8d& g, std::integer_sequence<int, A...> /*rows*/) {
  auto one_row = [&]<int Row>(std::integral_constant<int, Row>) {
    double row[C - Row + 1];
    accumulate_row<Row, C>(J, n, w, r, row);
    for (int b = Row; b < C; ++b) {
      H(Row, b) += row[b - Row];
      if (b != Row) H(b, Row) += row[b - Row];
    }
    g(Row) += row[C - Row];
  };
  (one_row(std::integral_constant<int, A>{}), ...);
}

}  // namespace detail
#endif

/// Adds sum_i w_i J_i J_i^T and sum_i w_i J_i r_i over the first C columns of J (column-major
/// arrays J[0..C-1], padded to kLanes with w = 0) to H and g. Lane accumulators in float, summed
/// in double.
template <int C>
void accumulate_normal_equations(const float* const* J, int count, const float* w,
                                 const float* r, Matrix8d& H, Vector8d& g) {
  static_assert(C >= 1 && C <= 8);
  const int n = pad_to_lanes(count);
#if defined(__AVX2__) && defined(__FMA__)
  detail::accumulate_rows<C>(J, n, w, r, H, g, std::make_integer_sequence<int, C>{});
#else
  // All terms at once in lane arrays the compiler vectorises: without the AVX2 intrinsics,
  // row by row is the slower of the two (docs/odometry.md, "Speed").
  constexpr int kH = C * (C + 1) / 2;
  alignas(32) float acc[kH + C][kLanes] = {};
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
  auto sum = [&](int t) {
    double s = 0.0;
    for (int k = 0; k < kLanes; ++k) s += static_cast<double>(acc[t][k]);
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
#endif
}

}  // namespace kestrel::odometry::kernels
