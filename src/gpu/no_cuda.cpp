// Built without the CUDA kernels: no device, and the CUDA engines cannot be made
// (resolve_backend never returns kCuda here, so these throws are a second line of defence).
#include "engines.hpp"

namespace kestrel::gpu::detail {
namespace {

[[noreturn]] void not_built() {
  throw BackendUnavailable("backend cuda: this build has no CUDA kernels (KESTREL_WITH_CUDA)");
}

}  // namespace

void query_cuda_devices(CudaDeviceInfo& info) {
  info.compiled = false;
  info.device_count = 0;
  info.reason = "not built with CUDA";
}

std::unique_ptr<StereoMatcher::Engine> make_cuda_stereo_engine(
    const sensor::BlockMatcherOptions&, const std::optional<RectifiedStereo>&) {
  not_built();
}
std::unique_ptr<ImageKernels::Engine> make_cuda_image_engine() { not_built(); }
std::unique_ptr<PhotometricStep::Engine> make_cuda_photometric_engine() { not_built(); }

}  // namespace kestrel::gpu::detail
