// The CUDA implementations behind the run-time backends: defined in cuda/*.cpp when the
// kernels are built, else in no_cuda.cpp (which throws; resolve_backend never picks them there).
#pragma once

#include <memory>
#include <optional>

#include "kestrel/gpu/backend.hpp"
#include "kestrel/gpu/image_kernels.hpp"
#include "kestrel/gpu/photometric_step.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"

namespace kestrel::gpu::detail {

/// Fills the device fields of `info` (compiled, device_count, name, reason).
void query_cuda_devices(CudaDeviceInfo& info);

std::unique_ptr<StereoMatcher::Engine> make_cuda_stereo_engine(
    const sensor::BlockMatcherOptions& options, const std::optional<RectifiedStereo>& rig);
std::unique_ptr<ImageKernels::Engine> make_cuda_image_engine();
std::unique_ptr<PhotometricStep::Engine> make_cuda_photometric_engine();

}  // namespace kestrel::gpu::detail
