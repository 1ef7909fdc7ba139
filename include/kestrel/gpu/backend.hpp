// Run-time choice between the CPU reference path and the CUDA kernels (docs/gpu.md).
#pragma once

#include <iosfwd>
#include <stdexcept>
#include <string>
#include <string_view>

namespace kestrel::gpu {

enum class Backend {
  kCpu,   ///< the CPU implementation (the reference)
  kCuda,  ///< the CUDA kernels; an error when there is no device
  kAuto,  ///< CUDA when a device is present, else the CPU with a one-line notice
};
std::string_view to_string(Backend backend);
/// "cpu", "cuda" or "auto"; throws std::invalid_argument otherwise.
Backend backend_from_string(std::string_view name);

/// A CUDA runtime call failed: the message names the call, the CUDA error and where.
class CudaError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The CUDA backend was asked for but cannot run (built without CUDA, or no device).
class BackendUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What this build and machine offer.
struct CudaDeviceInfo {
  bool compiled = false;  ///< built with the CUDA kernels (KESTREL_WITH_CUDA)
  int device_count = 0;   ///< usable devices (0 when not compiled or no driver)
  std::string name;       ///< device 0, e.g. "NVIDIA H100 80GB HBM3"
  int compute_major = 0, compute_minor = 0;
  std::string reason;  ///< why there is no device, when there is none
  [[nodiscard]] bool available() const { return compiled && device_count > 0; }
  [[nodiscard]] std::string describe() const;
};
/// Queried once (cudaGetDeviceCount / cudaGetDeviceProperties) and cached.
const CudaDeviceInfo& cuda_device_info();

/// kCpu or kCuda for `requested`: kAuto becomes kCuda when a device is present, else kCpu
/// after one line on `notice` (null: silent). kCuda without a device throws
/// BackendUnavailable with the reason.
Backend resolve_backend(Backend requested, std::ostream* notice);

/// Wall time of the stages of the last call, milliseconds. CUDA: CUDA events on the stream
/// (host -> device copies, kernels, device -> host copies); CPU: compute only.
struct StageTiming {
  double upload_ms = 0.0;
  double compute_ms = 0.0;
  double download_ms = 0.0;
  [[nodiscard]] double total_ms() const { return upload_ms + compute_ms + download_ms; }
};

}  // namespace kestrel::gpu
