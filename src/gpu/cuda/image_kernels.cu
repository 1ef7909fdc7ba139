// CUDA kernels of the image pyramids and gradients: one thread per output pixel running
// device/image.hpp.
#include "cuda_support.hpp"
#include "kestrel/gpu/device/image.hpp"
#include "launch.hpp"

namespace kestrel::gpu::cuda {
namespace {

struct Taps {
  float k[3];
};

__global__ void mean_2x2_kernel(const float* in, int in_w, float* out, int out_w, int out_h) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= out_w || y >= out_h) return;
  out[static_cast<std::ptrdiff_t>(y) * out_w + x] = device::mean_2x2_at(in, in_w, x, y);
}

__global__ void depth_2x2_kernel(const float* in, int in_w, float* out, int out_w, int out_h,
                                 float spread) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= out_w || y >= out_h) return;
  out[static_cast<std::ptrdiff_t>(y) * out_w + x] = device::depth_2x2_at(in, in_w, x, y, spread);
}

__global__ void gaussian_rows_kernel(const float* in, int w, int h, float* rows, Taps t) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  rows[static_cast<std::ptrdiff_t>(y) * w + x] = device::gaussian5_row_at(in, w, w, x, y, t.k);
}

__global__ void gaussian_columns_mean_kernel(const float* rows, int in_w, int in_h, float* out,
                                             int out_w, int out_h, Taps t) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= out_w || y >= out_h) return;
  out[static_cast<std::ptrdiff_t>(y) * out_w + x] =
      device::gaussian_mean_2x2_at(rows, in_w, in_h, x, y, t.k);
}

__global__ void gradients_kernel(const float* in, int w, int h, float* gx, float* gy) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const auto i = static_cast<std::ptrdiff_t>(y) * w + x;
  device::central_gradient_at(in, w, w, h, x, y, gx[i], gy[i]);
}

const dim3 kBlock(32, 8);
dim3 grid_for(int w, int h) { return dim3((w + 31) / 32, (h + 7) / 8); }

}  // namespace

void launch_mean_2x2(const float* in, int in_w, float* out, int out_w, int out_h,
                     cudaStream_t stream) {
  mean_2x2_kernel<<<grid_for(out_w, out_h), kBlock, 0, stream>>>(in, in_w, out, out_w, out_h);
  KESTREL_CUDA_CHECK_LAUNCH("2x2 mean kernel");
}

void launch_depth_2x2(const float* in, int in_w, float* out, int out_w, int out_h,
                      float max_relative_spread, cudaStream_t stream) {
  depth_2x2_kernel<<<grid_for(out_w, out_h), kBlock, 0, stream>>>(in, in_w, out, out_w, out_h,
                                                                  max_relative_spread);
  KESTREL_CUDA_CHECK_LAUNCH("depth 2x2 kernel");
}

void launch_gaussian_rows(const float* in, int in_w, int in_h, float* rows, const float k[3],
                          cudaStream_t stream) {
  const Taps t{{k[0], k[1], k[2]}};
  gaussian_rows_kernel<<<grid_for(in_w, in_h), kBlock, 0, stream>>>(in, in_w, in_h, rows, t);
  KESTREL_CUDA_CHECK_LAUNCH("Gaussian row kernel");
}

void launch_gaussian_columns_mean(const float* rows, int in_w, int in_h, float* out, int out_w,
                                  int out_h, const float k[3], cudaStream_t stream) {
  const Taps t{{k[0], k[1], k[2]}};
  gaussian_columns_mean_kernel<<<grid_for(out_w, out_h), kBlock, 0, stream>>>(rows, in_w, in_h, out,
                                                                              out_w, out_h, t);
  KESTREL_CUDA_CHECK_LAUNCH("Gaussian column + 2x2 mean kernel");
}

void launch_central_gradients(const float* in, int w, int h, float* gx, float* gy,
                              cudaStream_t stream) {
  gradients_kernel<<<grid_for(w, h), kBlock, 0, stream>>>(in, w, h, gx, gy);
  KESTREL_CUDA_CHECK_LAUNCH("central gradient kernel");
}

}  // namespace kestrel::gpu::cuda
