// Backend names, the device query and the run-time choice, with and without a device; the
// CUDA error path (runs without a GPU too: the runtime reports the missing driver).
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

#include "kestrel/gpu/backend.hpp"
#include "kestrel/gpu/image_kernels.hpp"
#include "kestrel/gpu/photometric_step.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"

#if KESTREL_HAVE_CUDA
#include "../../src/gpu/cuda/cuda_support.hpp"
#endif

namespace kestrel::gpu {
namespace {

TEST(Backend, NamesRoundTrip) {
  for (const Backend b : {Backend::kCpu, Backend::kCuda, Backend::kAuto}) {
    EXPECT_EQ(backend_from_string(to_string(b)), b);
  }
  EXPECT_THROW(backend_from_string("gpu"), std::invalid_argument);
}

TEST(Backend, DeviceInfoMatchesTheBuild) {
  const CudaDeviceInfo& info = cuda_device_info();
  EXPECT_EQ(info.compiled, KESTREL_HAVE_CUDA != 0);
  if (!info.available()) {
    EXPECT_FALSE(info.reason.empty());
  }
  std::cout << info.describe() << "\n";
}

TEST(Backend, CpuIsAlwaysCpu) {
  std::ostringstream notice;
  EXPECT_EQ(resolve_backend(Backend::kCpu, &notice), Backend::kCpu);
  EXPECT_TRUE(notice.str().empty());
}

TEST(Backend, AutoFallsBackToCpuWithANoticeAndCudaIsAnErrorWithoutADevice) {
  std::ostringstream notice;
  if (cuda_device_info().available()) {
    EXPECT_EQ(resolve_backend(Backend::kAuto, &notice), Backend::kCuda);
    EXPECT_EQ(resolve_backend(Backend::kCuda, &notice), Backend::kCuda);
    EXPECT_TRUE(notice.str().empty());
    return;
  }
  EXPECT_EQ(resolve_backend(Backend::kAuto, &notice), Backend::kCpu);
  const std::string line = notice.str();
  EXPECT_NE(line.find("using the CPU"), std::string::npos) << line;
  EXPECT_EQ(std::count(line.begin(), line.end(), '\n'), 1) << line;
  EXPECT_EQ(resolve_backend(Backend::kAuto, nullptr), Backend::kCpu);  // silent
  try {
    resolve_backend(Backend::kCuda, nullptr);
    FAIL() << "expected BackendUnavailable";
  } catch (const BackendUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("backend cuda"), std::string::npos) << e.what();
  }
  EXPECT_THROW(StereoMatcher({}, std::nullopt, Backend::kCuda, nullptr), BackendUnavailable);
  EXPECT_THROW(ImageKernels(Backend::kCuda, nullptr), BackendUnavailable);
  EXPECT_THROW(PhotometricStep(Backend::kCuda, nullptr), BackendUnavailable);
  std::ostringstream n2;
  const StereoMatcher m({}, std::nullopt, Backend::kAuto, &n2);
  EXPECT_EQ(m.backend(), Backend::kCpu);
  EXPECT_FALSE(n2.str().empty());
}

#if KESTREL_HAVE_CUDA
TEST(CudaErrors, FailedCallsBecomeCudaErrorsNamingTheCall) {
  try {
    KESTREL_CUDA_CHECK(cudaErrorInvalidValue);
    FAIL() << "expected CudaError";
  } catch (const CudaError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cudaErrorInvalidValue"), std::string::npos) << m;
    EXPECT_NE(m.find("test_backend.cpp"), std::string::npos) << m;
  }
  // An impossible allocation: out of memory with a device, no driver/device without one.
  cuda::DeviceBuffer<float> huge;
  EXPECT_THROW(huge.resize(std::size_t{1} << 60), CudaError);
  EXPECT_EQ(huge.capacity(), 0U);
}
#endif

}  // namespace
}  // namespace kestrel::gpu
