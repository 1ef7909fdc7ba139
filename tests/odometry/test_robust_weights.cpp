// Robust weights (thesis 3.8): the robust sigma of eq. 3.40 and the Tukey weight of eq. 3.39.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "kestrel/odometry/robust_weights.hpp"

namespace kestrel::odometry {
namespace {

TEST(RobustSigma, ThesisEquation340) {
  // |r| = 0, 1, ..., 100: upper median 50, m = 101, p = 6.
  std::vector<float> r(101);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = static_cast<float>(100 - i);
  EXPECT_DOUBLE_EQ(robust_sigma(r, 6), 1.4826 * (1.0 + 5.0 / 95.0) * 50.0);
  std::vector<float> few(6, 1.0F);
  EXPECT_EQ(robust_sigma(few, 6), 0.0);  // m <= p: no estimate
}

TEST(RobustSigma, GaussianResidualsGiveTheirSigma) {
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0F, 0.02F);
  std::vector<float> r(20000);
  for (auto& x : r) x = std::fabs(n(rng));
  EXPECT_NEAR(robust_sigma(r, 8), 0.02, 0.0008);  // MAD consistency factor 1.4826
}

TEST(Tukey, WeightIsCostDerivativeOverResidual) {
  const float c = 4.6851F;
  EXPECT_EQ(tukey_weight(0.0F, c), 1.0F);
  EXPECT_EQ(tukey_weight(c * 1.0001F, c), 0.0F);  // beyond c: rejected
  EXPECT_EQ(tukey_cost(10.0F, c), c * c / 6.0F);
  for (float u = -4.5F; u <= 4.5F; u += 0.25F) {  // rho'(u) = u w(u) (eq. 3.39 is w, not rho)
    const float h = 1e-3F;
    const float drho = (tukey_cost(u + h, c) - tukey_cost(u - h, c)) / (2.0F * h);
    EXPECT_NEAR(drho, u * tukey_weight(u, c), 2e-3F) << u;
  }
}

}  // namespace
}  // namespace kestrel::odometry
