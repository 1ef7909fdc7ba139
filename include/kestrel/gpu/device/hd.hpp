// Qualifiers and small helpers for the per-pixel / per-point functions that both the CUDA
// kernels and the host (g++) run: under nvcc they are __host__ __device__, elsewhere plain
// inline functions, so that the CPU tests execute exactly the arithmetic the kernels execute.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#if defined(__CUDACC__)
#define KESTREL_HD __host__ __device__ __forceinline__
#else
#define KESTREL_HD inline
#endif
// Loop unrolling for nvcc's device pass only (the host compilers do not know the pragma).
#if defined(__CUDA_ARCH__)
#define KESTREL_UNROLL _Pragma("unroll")
#else
#define KESTREL_UNROLL
#endif

namespace kestrel::gpu::device {

KESTREL_HD int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
KESTREL_HD int mini(int a, int b) { return a < b ? a : b; }
KESTREL_HD int maxi(int a, int b) { return a > b ? a : b; }
KESTREL_HD int absi(int v) { return v < 0 ? -v : v; }

KESTREL_HD int popcount64(std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  return __popcll(v);
#else
  return __builtin_popcountll(v);
#endif
}

/// +inf as a float (no `<limits>` on the device side).
KESTREL_HD float infinity_f() { return __builtin_huge_valf(); }

}  // namespace kestrel::gpu::device
