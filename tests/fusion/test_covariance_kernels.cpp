// The covariance row kernel on every SIMD target against its scalar reference: widths that do
// and do not fill the vectors (the filter's 15 and 22 among them), 1 to 12 terms.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kestrel/fusion/covariance_kernels.hpp"
#include "simd_targets.hpp"

namespace kestrel::fusion::kernels {
namespace {

// Runs `body(target)` on every SIMD target the kernel has for this CPU
// (tests/support/simd_targets.hpp).
template <class Body>
void on_every_simd_target(Body&& body) {
  test::on_every_simd_target(
      simd_targets(), [] { return simd_target(); }, body);
}

// Targets whose MulAdd rounds twice (no fused multiply-add): SSSE3, SSE4 and the emulations.
bool fuses(std::int64_t target) {
  return (target & (HWY_SSSE3 | HWY_SSE4 | HWY_EMU128 | HWY_SCALAR)) == 0;
}

TEST(FusionCovarianceKernels, CombineRowsEqualsTheScalarReference) {
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::vector<int> widths = {1, 2, 3, 4, 7, 8, 9, 15, 16, 17, 22, 31, 33};
  on_every_simd_target([&](std::int64_t target) {
    for (const int w : widths) {
      for (int terms = 1; terms <= 12; ++terms) {
        std::vector<std::vector<double>> data(static_cast<std::size_t>(terms));
        std::vector<const double*> rows;
        std::vector<double> coeffs;
        for (auto& row : data) {
          for (int j = 0; j < w; ++j) row.push_back(n(rng) * std::exp(3.0 * n(rng)));
          rows.push_back(row.data());
          coeffs.push_back(n(rng));
        }
        std::vector<double> simd(static_cast<std::size_t>(w), -1.0), ref(simd);
        combine_rows(rows.data(), coeffs.data(), terms, simd.data(), w);
        combine_rows_scalar(rows.data(), coeffs.data(), terms, ref.data(), w);
        for (int j = 0; j < w; ++j) {
          // Bit for bit with a fused multiply-add; else within 2 roundings of each term.
          double magnitude = 0.0;
          for (int t = 0; t < terms; ++t) magnitude += std::abs(coeffs[t] * data[t][j]);
          const double bound =
              fuses(target) ? 0.0
                            : 2.0 * terms * std::numeric_limits<double>::epsilon() * magnitude;
          EXPECT_LE(std::abs(simd[j] - ref[j]), bound)
              << "width " << w << ", terms " << terms << ", column " << j;
        }
      }
    }
  });
}

TEST(FusionCovarianceKernels, CombineRowsComputesTheLinearCombination) {
  // A known answer: 2 * [1..n] - 0.5 * [2, 4, ...] + 3 * [1, 1, ...] = [3 + j + 1 ...]:
  // out[j] = 2 (j + 1) - (j + 1) + 3 = j + 4.
  std::vector<double> a, b, c;
  for (int j = 0; j < 22; ++j) {
    a.push_back(j + 1.0);
    b.push_back(2.0 * (j + 1.0));
    c.push_back(1.0);
  }
  const double* rows[] = {a.data(), b.data(), c.data()};
  const double coeffs[] = {2.0, -0.5, 3.0};
  std::vector<double> out(22, 0.0);
  combine_rows(rows, coeffs, 3, out.data(), 22);
  for (int j = 0; j < 22; ++j) EXPECT_EQ(out[j], j + 4.0) << j;
}

TEST(FusionCovarianceKernels, RunOnTheBestSimdTargetOfTheCpu) {
  std::string names;
  for (const std::int64_t t : simd_targets()) names += std::string(" ") + hwy::TargetName(t);
  std::printf("fusion covariance kernel: SIMD targets%s; dispatch takes %s\n", names.c_str(),
              simd_target());
  EXPECT_STREQ(simd_target(), hwy::TargetName(simd_targets().front()));
}

}  // namespace
}  // namespace kestrel::fusion::kernels
