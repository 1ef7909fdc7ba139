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

void bracket_range(const float* residual, const std::uint8_t* valid, int begin, int count, float lo,
                   float hi, MedianBracket& b, float* scratch) {
  ref::bracket_range(residual, valid, begin, count, lo, hi, b, scratch);
}

}  // namespace kestrel::odometry::kernels
