// The covariance row kernel (covariance_kernels.hpp) in portable SIMD: Google Highway compiles
// this file once per target (foreach_target.h re-includes it), and combine_rows() calls the best
// target the CPU supports (HWY_DYNAMIC_DISPATCH).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "covariance_kernels.cpp"  // NOLINT: this file, found by its folder
#include "kestrel/fusion/covariance_kernels.hpp"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cmath>

#ifndef KESTREL_FUSION_COVARIANCE_KERNELS_SCALAR
#define KESTREL_FUSION_COVARIANCE_KERNELS_SCALAR
namespace kestrel::fusion::kernels {

void combine_rows_scalar(const double* const* rows, const double* coeffs, int terms, double* out,
                         int n) {
  for (int j = 0; j < n; ++j) {
    double acc = coeffs[0] * rows[0][j];
    for (int t = 1; t < terms; ++t) acc = std::fma(coeffs[t], rows[t][j], acc);
    out[j] = acc;
  }
}

}  // namespace kestrel::fusion::kernels
#endif  // KESTREL_FUSION_COVARIANCE_KERNELS_SCALAR

HWY_BEFORE_NAMESPACE();
namespace kestrel::fusion::kernels::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DD = hn::ScalableTag<double>;

// One vector of columns [j, j + lanes).
HWY_INLINE void combine_vector(const double* const* rows, const double* coeffs, int terms,
                               double* out, int j) {
  const DD d;
  auto acc = hn::Mul(hn::Set(d, coeffs[0]), hn::LoadU(d, rows[0] + j));
  for (int t = 1; t < terms; ++t) {
    acc = hn::MulAdd(hn::Set(d, coeffs[t]), hn::LoadU(d, rows[t] + j), acc);
  }
  hn::StoreU(acc, d, out + j);
}

void CombineRows(const double* const* rows, const double* coeffs, int terms, double* out, int n) {
  const int lanes = static_cast<int>(hn::Lanes(DD()));
  if (n < lanes) {
    combine_rows_scalar(rows, coeffs, terms, out, n);
    return;
  }
  int j = 0;
  for (; j + lanes <= n; j += lanes) combine_vector(rows, coeffs, terms, out, j);
  // The last columns: one more vector ending at n, overlapping the previous one (it recomputes
  // equal values), instead of a scalar tail.
  if (j < n) combine_vector(rows, coeffs, terms, out, n - lanes);
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace kestrel::fusion::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::fusion::kernels {

HWY_EXPORT(CombineRows);
HWY_EXPORT(TargetName);

void combine_rows(const double* const* rows, const double* coeffs, int terms, double* out, int n) {
  HWY_DYNAMIC_DISPATCH(CombineRows)(rows, coeffs, terms, out, n);
}

const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

std::vector<std::int64_t> simd_targets() { return hwy::SupportedAndGeneratedTargets(); }

}  // namespace kestrel::fusion::kernels
#endif  // HWY_ONCE
