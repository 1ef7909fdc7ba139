// Robust sigma from the median absolute residual, thesis eq. 3.40.
#include "kestrel/odometry/robust_weights.hpp"

#include "kestrel/odometry/alignment_kernels.hpp"

namespace kestrel::odometry {

double robust_sigma(std::span<float> abs_residuals, int parameters) {
  const auto m = static_cast<std::ptrdiff_t>(abs_residuals.size());
  if (m <= parameters) return 0.0;
  // Upper median (the element at m/2): the thesis' "median" for large m; O(m) selection.
  const float median =
      kernels::select_kth(abs_residuals.data(), static_cast<int>(m), static_cast<int>(m / 2));
  return robust_sigma_from_median(static_cast<double>(median), static_cast<int>(m), parameters);
}

double robust_sigma_from_median(double median_abs, int m, int parameters) {
  if (m <= parameters) return 0.0;
  return 1.4826 * (1.0 + 5.0 / static_cast<double>(m - parameters)) * median_abs;
}

}  // namespace kestrel::odometry
