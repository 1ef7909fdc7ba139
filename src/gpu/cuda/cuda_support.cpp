// CUDA error messages, the device query behind cuda_device_info().
#include "cuda_support.hpp"

#include <string>

#include "../engines.hpp"

namespace kestrel::gpu::cuda {

void throw_cuda_error(cudaError_t error, const char* call, const char* file, int line) {
  cudaGetLastError();  // clear a sticky launch error so that later calls report their own
  throw CudaError(std::string("CUDA error ") + cudaGetErrorName(error) + " (" +
                  std::to_string(static_cast<int>(error)) + "): " + cudaGetErrorString(error) +
                  " in " + call + " at " + file + ":" + std::to_string(line));
}

void ensure_device() {
  thread_local bool done = false;
  if (done) return;
  KESTREL_CUDA_CHECK(cudaSetDevice(0));
  KESTREL_CUDA_CHECK(cudaFree(nullptr));  // creates the context now
  done = true;
}

}  // namespace kestrel::gpu::cuda

namespace kestrel::gpu::detail {

void query_cuda_devices(CudaDeviceInfo& info) {
  info.compiled = true;
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess) {
    cudaGetLastError();
    info.device_count = 0;
    info.reason = std::string(cudaGetErrorName(e)) + ": " + cudaGetErrorString(e);
    return;
  }
  info.device_count = count;
  if (count == 0) {
    info.reason = "cudaGetDeviceCount found 0 devices";
    return;
  }
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, 0) == cudaSuccess) {
    info.name = prop.name;
    info.compute_major = prop.major;
    info.compute_minor = prop.minor;
  }
}

}  // namespace kestrel::gpu::detail
