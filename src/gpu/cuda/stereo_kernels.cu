// CUDA kernels of the block matcher: thin wrappers that run device/stereo.hpp per pixel
// (prefilter, select, finalize) or per column and disparity (cost volume).
#include "cuda_support.hpp"
#include "launch.hpp"

namespace kestrel::gpu::cuda {
namespace {

using device::StereoParams;

__global__ void prefilter_kernel(const std::uint8_t* left, const std::uint8_t* right,
                                 StereoParams p, std::uint8_t* pre_left, std::uint8_t* pre_right,
                                 std::uint64_t* census_left, std::uint64_t* census_right,
                                 std::uint8_t* gradient) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= p.width || y >= p.height) return;
  const int w = p.width, h = p.height;
  const auto i = static_cast<std::ptrdiff_t>(y) * w + x;
  gradient[i] = device::texture_gradient_at(left, w, w, x, y);
  if (p.census) {
    census_left[i] = device::census_at(left, w, w, h, x, y, p.census_radius);
    census_right[i] = device::census_at(right, w, w, h, x, y, p.census_radius);
  } else if (p.xsobel) {
    pre_left[i] = device::xsobel_at(left, w, w, h, x, y, p.prefilter_cap);
    pre_right[i] = device::xsobel_at(right, w, w, h, x, y, p.prefilter_cap);
  } else {
    pre_left[i] = left[i];
    pre_right[i] = right[i];
  }
}

// One thread per (x, d) slides down kCostRowsPerThread rows.
template <typename Pixel>
__global__ void cost_kernel(const Pixel* left, const Pixel* right, StereoParams p, int rows,
                            std::uint16_t* volume) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int di = blockIdx.y * blockDim.y + threadIdx.y;
  const int y0 = blockIdx.z * rows;
  if (x >= p.width || di >= p.num) return;
  device::cost_column(left, right, p.width, p, x, di, y0, min(y0 + rows, p.height), volume);
}

__global__ void select_kernel(const std::uint16_t* volume, const std::uint8_t* gradient,
                              StereoParams p, std::int16_t* best_index, std::uint8_t* state,
                              std::uint16_t* right_min) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= p.width || y >= p.height) return;
  const std::uint16_t* vol = volume + static_cast<std::ptrdiff_t>(y) * p.num * p.width;
  const std::uint32_t tex =
      device::texture_sum_at(gradient, p.width, p.width, p.height, x, y, p.radius);
  int best = -1;
  const auto i = static_cast<std::ptrdiff_t>(y) * p.width + x;
  state[i] = device::select_pixel(vol, p, x, tex, best);
  best_index[i] = static_cast<std::int16_t>(best);
  right_min[i] = static_cast<std::uint16_t>(device::right_min_at(vol, p, x));
}

__global__ void finalize_kernel(const std::uint16_t* volume, const std::uint16_t* right_min,
                                const std::int16_t* best_index, const std::uint8_t* state,
                                StereoParams p, float* disparity, std::uint32_t* counts) {
  __shared__ std::uint32_t block_counts[device::kStateCount];
  const int tid = threadIdx.y * blockDim.x + threadIdx.x;
  if (tid < device::kStateCount) block_counts[tid] = 0;
  __syncthreads();
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < p.width && y < p.height) {
    const auto row = static_cast<std::ptrdiff_t>(y) * p.width;
    const std::uint16_t* vol = volume + row * p.num;
    float d = 0.0F;
    const std::uint8_t s =
        device::finalize_pixel(vol, right_min + row, p, x, state[row + x], best_index[row + x], d);
    disparity[row + x] = d;
    atomicAdd(&block_counts[s], 1U);
  }
  __syncthreads();
  if (tid < device::kStateCount && block_counts[tid] > 0)
    atomicAdd(&counts[tid], block_counts[tid]);
}

dim3 pixel_grid(const StereoParams& p, dim3 block) {
  return dim3((p.width + block.x - 1) / block.x, (p.height + block.y - 1) / block.y);
}

}  // namespace

void launch_stereo_prefilter(const std::uint8_t* left, const std::uint8_t* right,
                             const StereoParams& p, std::uint8_t* pre_left, std::uint8_t* pre_right,
                             std::uint64_t* census_left, std::uint64_t* census_right,
                             std::uint8_t* gradient, cudaStream_t stream) {
  const dim3 block(32, 8);
  prefilter_kernel<<<pixel_grid(p, block), block, 0, stream>>>(left, right, p, pre_left, pre_right,
                                                               census_left, census_right, gradient);
  KESTREL_CUDA_CHECK_LAUNCH("stereo prefilter kernel");
}

void launch_stereo_cost(const std::uint8_t* pre_left, const std::uint8_t* pre_right,
                        const std::uint64_t* census_left, const std::uint64_t* census_right,
                        const StereoParams& p, std::uint16_t* volume, cudaStream_t stream) {
  const int rows = device::kCostRowsPerThread;
  const dim3 block(32, 4);
  const dim3 grid((p.width + 31) / 32, (p.num + 3) / 4, (p.height + rows - 1) / rows);
  if (p.census) {
    cost_kernel<<<grid, block, 0, stream>>>(census_left, census_right, p, rows, volume);
  } else {
    cost_kernel<<<grid, block, 0, stream>>>(pre_left, pre_right, p, rows, volume);
  }
  KESTREL_CUDA_CHECK_LAUNCH("stereo cost kernel");
}

void launch_stereo_select(const std::uint16_t* volume, const std::uint8_t* gradient,
                          const StereoParams& p, std::int16_t* best_index, std::uint8_t* state,
                          std::uint16_t* right_min, cudaStream_t stream) {
  const dim3 block(32, 8);
  select_kernel<<<pixel_grid(p, block), block, 0, stream>>>(volume, gradient, p, best_index, state,
                                                            right_min);
  KESTREL_CUDA_CHECK_LAUNCH("stereo select kernel");
}

void launch_stereo_finalize(const std::uint16_t* volume, const std::uint16_t* right_min,
                            const std::int16_t* best_index, const std::uint8_t* state,
                            const StereoParams& p, float* disparity, std::uint32_t* counts,
                            cudaStream_t stream) {
  KESTREL_CUDA_CHECK(
      cudaMemsetAsync(counts, 0, sizeof(std::uint32_t) * device::kStateCount, stream));
  const dim3 block(32, 8);
  finalize_kernel<<<pixel_grid(p, block), block, 0, stream>>>(volume, right_min, best_index, state,
                                                              p, disparity, counts);
  KESTREL_CUDA_CHECK_LAUNCH("stereo finalize kernel");
}

}  // namespace kestrel::gpu::cuda
