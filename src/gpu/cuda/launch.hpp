// The kernel launchers (defined in the .cu files): device pointers in, nothing else, so that
// nvcc compiles no OpenCV or Eigen. Pitches are in elements. Each checks its launch.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "kestrel/gpu/device/photometric.hpp"
#include "kestrel/gpu/device/stereo.hpp"

namespace kestrel::gpu::cuda {

// Stereo (stereo_kernels.cu); images are width x height with row length p.width.
/// Prefiltered (SAD) or census images of both views, and the left texture gradient.
void launch_stereo_prefilter(const std::uint8_t* left, const std::uint8_t* right,
                             const device::StereoParams& p, std::uint8_t* pre_left,
                             std::uint8_t* pre_right, std::uint64_t* census_left,
                             std::uint64_t* census_right, std::uint8_t* gradient,
                             cudaStream_t stream);
/// The cost volume [y][d - min_d][x] (uint16).
void launch_stereo_cost(const std::uint8_t* pre_left, const std::uint8_t* pre_right,
                        const std::uint64_t* census_left, const std::uint64_t* census_right,
                        const device::StereoParams& p, std::uint16_t* volume, cudaStream_t stream);
/// Winner, texture and uniqueness per pixel, and the right view's least costs.
void launch_stereo_select(const std::uint16_t* volume, const std::uint8_t* gradient,
                          const device::StereoParams& p, std::int16_t* best_index,
                          std::uint8_t* state, std::uint16_t* right_min, cudaStream_t stream);
/// Left-right check, subpixel, depth range: the disparity and the count per PixelState
/// (`counts` has kStateCount entries, zeroed here).
void launch_stereo_finalize(const std::uint16_t* volume, const std::uint16_t* right_min,
                            const std::int16_t* best_index, const std::uint8_t* state,
                            const device::StereoParams& p, float* disparity, std::uint32_t* counts,
                            cudaStream_t stream);

// Image (image_kernels.cu); contiguous images (pitch = width).
void launch_mean_2x2(const float* in, int in_w, float* out, int out_w, int out_h,
                     cudaStream_t stream);
void launch_depth_2x2(const float* in, int in_w, float* out, int out_w, int out_h,
                      float max_relative_spread, cudaStream_t stream);
/// Row pass of the 5-tap Gaussian over the whole in_w x in_h image.
void launch_gaussian_rows(const float* in, int in_w, int in_h, float* rows, const float k[3],
                          cudaStream_t stream);
/// Column pass and 2x2 mean: out_w x out_h from the row-filtered image.
void launch_gaussian_columns_mean(const float* rows, int in_w, int in_h, float* out, int out_w,
                                  int out_h, const float k[3], cudaStream_t stream);
void launch_central_gradients(const float* in, int w, int h, float* gx, float* gy,
                              cudaStream_t stream);

// Photometric (photometric_kernels.cu).
/// Residuals and validity per point; adds the number inside to *inside (zeroed here).
void launch_warp_residuals(const device::PointsView& points, const float* image,
                           const device::WarpParams& p, float* residual, std::uint8_t* valid,
                           int* inside, cudaStream_t stream);
/// Per block (device::normal_equation_blocks of them): the sums of device::accumulate_point
/// over its points, kNormalTerms floats.
void launch_normal_equations(const device::PointsView& points, const float* residual,
                             const std::uint8_t* valid, float inv_sigma, float c, int blocks,
                             float* partials, cudaStream_t stream);

}  // namespace kestrel::gpu::cuda
