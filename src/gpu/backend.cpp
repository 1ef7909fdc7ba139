// Backend names, the device query and the run-time choice.
#include "kestrel/gpu/backend.hpp"

#include <ostream>
#include <sstream>

#include "engines.hpp"

namespace kestrel::gpu {

std::string_view to_string(Backend backend) {
  switch (backend) {
    case Backend::kCpu:
      return "cpu";
    case Backend::kCuda:
      return "cuda";
    case Backend::kAuto:
      return "auto";
  }
  return "unknown";
}

Backend backend_from_string(std::string_view name) {
  if (name == "cpu") return Backend::kCpu;
  if (name == "cuda") return Backend::kCuda;
  if (name == "auto") return Backend::kAuto;
  throw std::invalid_argument("backend '" + std::string(name) + "': expected cpu, cuda or auto");
}

std::string CudaDeviceInfo::describe() const {
  std::ostringstream os;
  if (!compiled) return "CUDA: not built (KESTREL_WITH_CUDA off or nvcc not found)";
  if (device_count == 0) {
    os << "CUDA: no device (" << reason << ")";
    return os.str();
  }
  os << "CUDA: " << device_count << " device(s); device 0 " << name << ", compute capability "
     << compute_major << "." << compute_minor;
  return os.str();
}

const CudaDeviceInfo& cuda_device_info() {
  static const CudaDeviceInfo info = [] {
    CudaDeviceInfo i;
    detail::query_cuda_devices(i);
    return i;
  }();
  return info;
}

Backend resolve_backend(Backend requested, std::ostream* notice) {
  if (requested == Backend::kCpu) return Backend::kCpu;
  const CudaDeviceInfo& info = cuda_device_info();
  if (info.available()) return Backend::kCuda;
  if (requested == Backend::kCuda) {
    throw BackendUnavailable("backend cuda: " + info.describe());
  }
  if (notice != nullptr)
    *notice << "kestrel: backend auto: " << info.describe() << "; using the CPU\n";
  return Backend::kCpu;
}

}  // namespace kestrel::gpu
