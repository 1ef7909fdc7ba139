// The scalar references of the alignment kernels as the build's baseline target rounds them: the
// SIMD kernels (alignment_kernels.cpp) run these on the points that do not fill a vector. Their
// source is alignment_kernels_reference-inl.h, whose per-target copies serve the public *_scalar
// functions; the tails keep the baseline copy, so that the tracker's results do not depend on
// which SIMD target contracts a * b + c into an FMA in them (a rounding-level change that moves
// a chaotic sequence such as the rendered corridor by several per cent). Private to the odometry
// module.
#pragma once

#include <cstdint>

#include "kestrel/odometry/alignment_kernels.hpp"

namespace kestrel::odometry::kernels {

/// abs_median's counts around its bracket [lo, hi): valid points, those below, and those inside
/// (packed into scratch[0..inside)).
struct MedianBracket {
  int valid = 0, below = 0, inside = 0;
};

int warp_range_scalar(const PointsView& p, const LevelImage& cur, const FloatPose& T, float alpha,
                      float beta, int begin, float* residual, std::uint8_t* valid,
                      Sampling sampling);

int point_to_plane_range_scalar(const PlanePointsView& p, const LevelImage& dep, const FloatPose& T,
                                float max_spread, int begin, float* res, std::uint8_t* val,
                                float* const* jac);

double tukey_cost_range(const float* residual, const std::uint8_t* valid, int begin, int count,
                        float inv_sigma, float c);

WeightSums tukey_weights_range(const float* residual, const std::uint8_t* valid, int begin,
                               int count, float inv_sigma, float c, float* weight);

void bracket_range(const float* residual, const std::uint8_t* valid, int begin, int count, float lo,
                   float hi, MedianBracket& b, float* scratch);

/// surface_normal_row_scalar over columns [from, to): the SIMD version's last columns.
void surface_normal_columns(const NormalRow& row, int from, int to, float* nx, float* ny,
                            std::uint8_t* ok);

}  // namespace kestrel::odometry::kernels
