// Robust weighting of photometric residuals (thesis 3.8): Tukey's bi-weight on residuals
// scaled by a robust sigma from the median absolute residual.
#pragma once

#include <cstddef>
#include <span>

namespace kestrel::odometry {

/// Tukey bi-weight, thesis eq. 3.39 read as the weight w(u) (the text calls it rho):
/// (1 - (u/c)^2)^2 for |u| <= c, else 0. u is the residual divided by sigma.
inline float tukey_weight(float u, float c) {
  const float s = u / c;
  const float t = 1.0F - s * s;
  return (s * s <= 1.0F) ? t * t : 0.0F;
}

/// Tukey cost rho(u) = c^2/6 (1 - (1 - (u/c)^2)^3) for |u| <= c, else c^2/6; rho' = u w(u).
inline float tukey_cost(float u, float c) {
  const float s = u / c;
  const float t = 1.0F - s * s;
  const float k = c * c / 6.0F;
  return (s * s <= 1.0F) ? k * (1.0F - t * t * t) : k;
}

/// sigma = 1.4826 (1 + 5 / (m - p)) median|r| (thesis eq. 3.40) of the m values in
/// `abs_residuals` (reordered in place: nth_element), p = `parameters`. 0 for m <= p.
double robust_sigma(std::span<float> abs_residuals, int parameters);

/// The same sigma from the upper median of the m absolute residuals (kernels::abs_median).
double robust_sigma_from_median(double median_abs, int m, int parameters);

}  // namespace kestrel::odometry
