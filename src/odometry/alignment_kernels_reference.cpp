// The SIMD kernels' tails (alignment_kernels_reference.hpp): the scalar references compiled once,
// for the build's baseline target (Highway's static target).
#include "alignment_kernels_reference.hpp"

#include <hwy/highway.h>

#include "alignment_kernels_reference-inl.h"

namespace kestrel::odometry::kernels {
namespace ref = HWY_NAMESPACE::reference;

int warp_range_scalar(const PointsView& p, const LevelImage& cur, const FloatPose& T, float alpha,
                      float beta, int begin, float* residual, std::uint8_t* valid,
                      Sampling sampling) {
  return ref::warp_range(p, cur, T, alpha, beta, begin, residual, valid, sampling);
}

int point_to_plane_range_scalar(const PlanePointsView& p, const LevelImage& dep, const FloatPose& T,
                                float max_spread, int begin, float* res, std::uint8_t* val,
                                float* const* jac) {
  return ref::point_to_plane_range(p, dep, T, max_spread, begin, res, val, jac);
}

double tukey_cost_range(const float* residual, const std::uint8_t* valid, int begin, int count,
                        float inv_sigma, float c) {
  return ref::tukey_cost_range(residual, valid, begin, count, inv_sigma, c);
}

WeightSums tukey_weights_range(const float* residual, const std::uint8_t* valid, int begin,
                               int count, float inv_sigma, float c, float* weight) {
  return ref::tukey_weights_range(residual, valid, begin, count, inv_sigma, c, weight);
}

namespace {

// surface_normal_row at pixel u: the same float operations in the same order as the SIMD one.
bool surface_normal_at(const NormalRow& r, int u, float& nx, float& ny) {
  const float z0 = r.mid[u], zl = r.mid[u - 1], zr = r.mid[u + 1];
  const float zu = r.up[u], zd = r.down[u];
  for (const float z : {zl, zr, zu, zd}) {
    if (!(z > 0.0F && z < 1e3F) || std::fabs(z - z0) > r.max_spread * z0) return false;
  }
  const float xu = (static_cast<float>(u) - r.cx) / r.fx;
  const float yv = (static_cast<float>(r.v) - r.cy) / r.fy;
  const float ix = 1.0F / r.fx, iy = 1.0F / r.fy;
  // dx = X(u+1, zr) - X(u-1, zl), dy = X(v+1, zd) - X(v-1, zu) (back-projected).
  const float ax = (xu + ix) * zr - (xu - ix) * zl, ay = yv * (zr - zl), az = zr - zl;
  const float bx = xu * (zd - zu), by = (yv + iy) * zd - (yv - iy) * zu, bz = zd - zu;
  float n0 = ay * bz - az * by;
  float n1 = az * bx - ax * bz;
  const float n2 = ax * by - ay * bx;
  const float len = std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
  if (!(len > 0.0F)) return false;
  const float px = xu * z0, py = yv * z0;
  float dot = (n0 * px + n1 * py + n2 * z0) / len;
  if (dot > 0.0F) {
    n0 = -n0;
    n1 = -n1;
    dot = -dot;
  }
  if (!(-dot > 0.2F * std::sqrt(px * px + py * py + z0 * z0))) return false;
  nx = n0 / len;
  ny = n1 / len;
  return true;
}

}  // namespace

void surface_normal_row_scalar(const NormalRow& row, float* nx, float* ny, std::uint8_t* ok) {
  surface_normal_columns(row, 1, row.width - 1, nx, ny, ok);
}

void surface_normal_columns(const NormalRow& row, int from, int to, float* nx, float* ny,
                            std::uint8_t* ok) {
  for (int u = from; u < to; ++u) {
    ok[u] = surface_normal_at(row, u, nx[u], ny[u]) ? 1 : 0;
  }
}

void bracket_range(const float* residual, const std::uint8_t* valid, int begin, int count, float lo,
                   float hi, MedianBracket& b, float* scratch) {
  ref::bracket_range(residual, valid, begin, count, lo, hi, b, scratch);
}

}  // namespace kestrel::odometry::kernels
