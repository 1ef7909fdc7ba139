// CUDA kernels of the tracker's inner loop: warp + residual per point, and the normal
// equations as per-thread sums of device::accumulate_point reduced by warp shuffles and shared
// memory into one partial per block (the host adds the partials in double, in block order).
#include "cuda_support.hpp"
#include "launch.hpp"

namespace kestrel::gpu::cuda {
namespace {

constexpr int kThreads = device::kNormalThreads;
constexpr int kWarps = kThreads / 32;

__global__ void warp_kernel(device::PointsView pts, const float* image, device::WarpParams p,
                            float* residual, std::uint8_t* valid, int* inside) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  int in = 0;
  if (i < pts.count) {
    float r = 0.0F;
    in = device::warp_residual(p, image, pts.x[i], pts.y[i], pts.z[i], pts.intensity[i], r) ? 1 : 0;
    residual[i] = r;
    valid[i] = static_cast<std::uint8_t>(in);
  }
  const int block_inside = __syncthreads_count(in);
  if (threadIdx.x == 0 && block_inside > 0) atomicAdd(inside, block_inside);
}

__global__ void __launch_bounds__(kThreads)
    normal_equations_kernel(device::PointsView pts, const float* residual,
                            const std::uint8_t* valid, float inv_sigma, float c, float* partials) {
  float acc[device::kNormalTerms];
#pragma unroll
  for (int t = 0; t < device::kNormalTerms; ++t) acc[t] = 0.0F;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < pts.count; i += gridDim.x * blockDim.x) {
    float jac[8];
#pragma unroll
    for (int a = 0; a < 8; ++a) jac[a] = pts.jac[a][i];
    device::accumulate_point(jac, residual[i], valid[i] != 0, inv_sigma, c, acc);
  }
  __shared__ float warp_sums[kWarps][device::kNormalTerms];
  const int lane = threadIdx.x % 32;
  const int warp = threadIdx.x / 32;
#pragma unroll
  for (int t = 0; t < device::kNormalTerms; ++t) {
    float v = acc[t];
#pragma unroll
    for (int offset = 16; offset > 0; offset /= 2) v += __shfl_down_sync(0xffffffffU, v, offset);
    if (lane == 0) warp_sums[warp][t] = v;
  }
  __syncthreads();
  if (threadIdx.x < device::kNormalTerms) {
    float s = 0.0F;
    for (int k = 0; k < kWarps; ++k) s += warp_sums[k][threadIdx.x];
    partials[static_cast<std::ptrdiff_t>(blockIdx.x) * device::kNormalTerms + threadIdx.x] = s;
  }
}

}  // namespace

void launch_warp_residuals(const device::PointsView& points, const float* image,
                           const device::WarpParams& p, float* residual, std::uint8_t* valid,
                           int* inside, cudaStream_t stream) {
  KESTREL_CUDA_CHECK(cudaMemsetAsync(inside, 0, sizeof(int), stream));
  if (points.count == 0) return;
  const int blocks = (points.count + kThreads - 1) / kThreads;
  warp_kernel<<<blocks, kThreads, 0, stream>>>(points, image, p, residual, valid, inside);
  KESTREL_CUDA_CHECK_LAUNCH("warp/residual kernel");
}

void launch_normal_equations(const device::PointsView& points, const float* residual,
                             const std::uint8_t* valid, float inv_sigma, float c, int blocks,
                             float* partials, cudaStream_t stream) {
  normal_equations_kernel<<<blocks, kThreads, 0, stream>>>(points, residual, valid, inv_sigma, c,
                                                           partials);
  KESTREL_CUDA_CHECK_LAUNCH("normal-equation kernel");
}

}  // namespace kestrel::gpu::cuda
