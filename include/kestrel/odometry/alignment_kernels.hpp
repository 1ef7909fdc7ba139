// The per-iteration kernels of the direct alignment (thesis 3.5-3.10) on structure-of-arrays
// point data: warp + bilinear sample + photometric residual, Tukey cost and weights, and the
// weighted normal equations. DirectTracker calls them once per Gauss-Newton iteration; they are
// free functions on plain arrays so that each can be tested and benchmarked alone. Each is
// written once in portable SIMD (Google Highway: AVX-512, AVX2, SSE4 on x86, NEON on ARM, the
// best one the CPU has chosen at run time) and has one scalar reference (*_scalar), whose one
// source is compiled for the same targets and runs on the one the kernels run on.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"  // Matrix8d, Vector8d

namespace kestrel::odometry::kernels {

/// The most float lanes a SIMD target of the kernels uses (16: AVX-512). Per-point arrays handed
/// to accumulate_normal_equations are padded to a multiple of it, with zero weights.
inline constexpr int kLanes = 16;
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
/// number of valid points. NaN coordinates are invalid.
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
/// Elsewhere r, J and valid are 0. Returns the number of valid points.
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
/// The reference implementation (one point at a time).
double tukey_cost_sum_scalar(const float* residual, const std::uint8_t* valid, int count,
                             float inv_sigma, float c);

struct WeightSums {
  double cost = 0.0;  ///< as tukey_cost_sum
  int inliers = 0;    ///< valid points with |r / sigma| < c
};
/// w_i = w(r_i / sigma) / sigma^2 (Tukey weight, thesis eq. 3.39, carrying 1/sigma^2 so that
/// H^-1 is the covariance); 0 for invalid points. Returns the cost and inlier count as well.
WeightSums tukey_weights(const float* residual, const std::uint8_t* valid, int count,
                         float inv_sigma, float c, float* weight);
/// The reference implementation (one point at a time).
WeightSums tukey_weights_scalar(const float* residual, const std::uint8_t* valid, int count,
                                float inv_sigma, float c, float* weight);

/// Writes |r_i| of the valid points, packed, to `out`; returns how many (the input of
/// robust_sigma, thesis eq. 3.40).
int gather_abs_valid(const float* residual, const std::uint8_t* valid, int count, float* out);
/// The reference implementation (one point at a time).
int gather_abs_valid_scalar(const float* residual, const std::uint8_t* valid, int count,
                            float* out);

/// The element at index k (0 <= k < n) of the n values in v sorted ascending (no NaN); reorders
/// v. The median of robust_sigma and abs_median (thesis eq. 3.40), and of the depth levels.
float select_kth(float* v, int n, int k);
/// The reference implementation.
float select_kth_scalar(float* v, int n, int k);

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

/// Adds sum_i w_i J_i J_i^T and sum_i w_i J_i r_i over the first C columns of J (column-major
/// arrays J[0..C-1], padded to kLanes with w = 0) to H and g. Lane accumulators in float, summed
/// in double. Defined for C = 6 (the point-to-plane term) and C = 8 (pose, gain and bias).
template <int C>
void accumulate_normal_equations(const float* const* J, int count, const float* w, const float* r,
                                 Matrix8d& H, Vector8d& g);
template <>
void accumulate_normal_equations<6>(const float* const* J, int count, const float* w,
                                    const float* r, Matrix8d& H, Vector8d& g);
template <>
void accumulate_normal_equations<8>(const float* const* J, int count, const float* w,
                                    const float* r, Matrix8d& H, Vector8d& g);
/// The reference implementation (one point at a time, in double). Needs no padding.
template <int C>
void accumulate_normal_equations_scalar(const float* const* J, int count, const float* w,
                                        const float* r, Matrix8d& H, Vector8d& g);
template <>
void accumulate_normal_equations_scalar<6>(const float* const* J, int count, const float* w,
                                           const float* r, Matrix8d& H, Vector8d& g);
template <>
void accumulate_normal_equations_scalar<8>(const float* const* J, int count, const float* w,
                                           const float* r, Matrix8d& H, Vector8d& g);

/// One row v of a depth level (metres) with its neighbours above and below, and the level's
/// pinhole model: the input of surface_normal_row.
struct NormalRow {
  const float* up = nullptr;
  const float* mid = nullptr;
  const float* down = nullptr;
  int width = 0;
  int v = 0;
  float fx = 1.0F, fy = 1.0F, cx = 0.0F, cy = 0.0F;
  /// The neighbours' largest relative depth difference to the centre's.
  float max_spread = 0.0F;
};
/// For u in [1, width - 1): the x and y components of the unit surface normal at pixel (u, v),
/// facing the camera, from the cross product of the back-projected central differences (left /
/// right, up / down), where the four neighbours are depths in (0, 1e3) within max_spread of the
/// centre's (relative) and the surface is not grazing (the normal within ~78 deg of the viewing
/// ray): ok[u] = 1. Elsewhere ok[u] = 0 and nx[u], ny[u] are unspecified; u = 0 and width - 1
/// are not written. The centre's own depth is not range-checked. The candidates' normals of
/// the geometric fallback's normal-space sample (direct_tracker.cpp, bin_normals).
void surface_normal_row(const NormalRow& row, float* nx, float* ny, std::uint8_t* ok);
/// The reference implementation (one pixel at a time); surface_normal_row gives its results to
/// float rounding (targets with fused multiply-adds round differently), so a test at its
/// threshold may go the other way.
void surface_normal_row_scalar(const NormalRow& row, float* nx, float* ny, std::uint8_t* ok);

/// The SIMD target the kernels run on in this process (e.g. "AVX3", "AVX2", "NEON").
const char* simd_target();
/// Every SIMD target the kernels are compiled for that this CPU runs, best first, as Highway
/// target bits (hwy::TargetName names them; tests select one with
/// hwy::SetSupportedTargetsForTest).
std::vector<std::int64_t> simd_targets();

}  // namespace kestrel::odometry::kernels
