// CUDA runtime helpers for the host side of the kernels: errors turned into CudaError, RAII
// owners of device memory, streams and events. Host C++ only (g++ with the CUDA headers).
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <utility>

#include "kestrel/gpu/backend.hpp"

namespace kestrel::gpu::cuda {

/// Throws CudaError "CUDA error NAME (CODE): DESCRIPTION in CALL at FILE:LINE".
[[noreturn]] void throw_cuda_error(cudaError_t error, const char* call, const char* file, int line);

inline void check(cudaError_t error, const char* call, const char* file, int line) {
  if (error != cudaSuccess) throw_cuda_error(error, call, file, line);
}

#define KESTREL_CUDA_CHECK(call) ::kestrel::gpu::cuda::check((call), #call, __FILE__, __LINE__)
/// After a kernel launch: launch-configuration errors now, execution errors at the next sync.
#define KESTREL_CUDA_CHECK_LAUNCH(what) \
  ::kestrel::gpu::cuda::check(cudaGetLastError(), (what), __FILE__, __LINE__)

/// Device memory for `count` elements of T; grows (never shrinks) on resize, so a buffer sized
/// once is reused without allocation.
template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t count) { resize(count); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& other) noexcept
      : ptr_(std::exchange(other.ptr_, nullptr)), capacity_(std::exchange(other.capacity_, 0)) {}
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    if (this != &other) {
      release();
      ptr_ = std::exchange(other.ptr_, nullptr);
      capacity_ = std::exchange(other.capacity_, 0);
    }
    return *this;
  }

  void resize(std::size_t count) {
    if (count <= capacity_) return;
    release();
    void* p = nullptr;
    KESTREL_CUDA_CHECK(cudaMalloc(&p, count * sizeof(T)));
    ptr_ = static_cast<T*>(p);
    capacity_ = count;
  }
  [[nodiscard]] T* data() { return ptr_; }
  [[nodiscard]] const T* data() const { return ptr_; }
  [[nodiscard]] std::size_t capacity() const { return capacity_; }

 private:
  void release() noexcept {
    if (ptr_ != nullptr) cudaFree(ptr_);  // errors at teardown are not actionable
    ptr_ = nullptr;
    capacity_ = 0;
  }
  T* ptr_ = nullptr;
  std::size_t capacity_ = 0;
};

class Stream {
 public:
  Stream() { KESTREL_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking)); }
  ~Stream() { cudaStreamDestroy(stream_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  [[nodiscard]] cudaStream_t get() const { return stream_; }
  void synchronize() const { KESTREL_CUDA_CHECK(cudaStreamSynchronize(stream_)); }

 private:
  cudaStream_t stream_ = nullptr;
};

class Event {
 public:
  Event() { KESTREL_CUDA_CHECK(cudaEventCreate(&event_)); }
  ~Event() { cudaEventDestroy(event_); }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  void record(const Stream& s) { KESTREL_CUDA_CHECK(cudaEventRecord(event_, s.get())); }
  /// Milliseconds from `start` to this event (both recorded, this one completed).
  [[nodiscard]] float ms_since(const Event& start) const {
    float ms = 0.0F;
    KESTREL_CUDA_CHECK(cudaEventElapsedTime(&ms, start.event_, event_));
    return ms;
  }

 private:
  cudaEvent_t event_ = nullptr;
};

/// Four events around the stages of one call: upload, compute, download.
struct StageEvents {
  Event start, uploaded, computed, downloaded;
  void fill(StageTiming& t) const {
    t.upload_ms += static_cast<double>(uploaded.ms_since(start));
    t.compute_ms += static_cast<double>(computed.ms_since(uploaded));
    t.download_ms += static_cast<double>(downloaded.ms_since(computed));
  }
};

/// Makes device 0 current once per thread and checks that it works (a context error here is
/// clearer than at the first kernel).
void ensure_device();

}  // namespace kestrel::gpu::cuda
