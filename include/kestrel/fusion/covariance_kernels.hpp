// The filter's covariance products as sums of scaled rows: the propagation F P F^T with the
// transition's sparse 3x3 blocks (thesis eq. 4.6) and the Joseph update's 25x6 products (thesis
// eq. 4.8) each build an output row as a short linear combination of contiguous input rows. One
// portable SIMD kernel (Google Highway, the best target of the CPU chosen at run time) does that,
// with one scalar reference (*_scalar) that the tests hold it to.
//
// Why a kernel: Eigen's fixed-size products are vectorised at compile time, for SSE2 without FMA
// in a build without -march=native; this kernel uses AVX-512, AVX2 + FMA or NEON where the CPU
// has them (docs/onboard.md, "Portable release build").
#pragma once

#include <cstdint>
#include <vector>

namespace kestrel::fusion::kernels {

/// out[j] = sum over t of coeffs[t] * rows[t][j], j in [0, n), terms >= 1, accumulated in the
/// order t = 0, 1, ... (the first term a product, each next one a multiply-add). `out` must not
/// overlap any row. Equal to the scalar reference bit for bit on targets with a fused
/// multiply-add; elsewhere within 2 rounding errors per term.
void combine_rows(const double* const* rows, const double* coeffs, int terms, double* out, int n);
void combine_rows_scalar(const double* const* rows, const double* coeffs, int terms, double* out,
                         int n);

/// The Highway target the kernel runs on here ("AVX3", "AVX2", "NEON", ...), and every target
/// compiled in that this CPU supports (what the tests run).
const char* simd_target();
std::vector<std::int64_t> simd_targets();

}  // namespace kestrel::fusion::kernels
