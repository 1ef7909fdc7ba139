// Comparison helpers, central finite differences and long-double series references that the
// geometry tests check the closed forms against.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace kestrel::test {

/// max |a - b| over all coefficients.
template <typename A, typename B>
double max_abs_diff(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  return (a.derived() - b.derived()).cwiseAbs().maxCoeff();
}

/// Passes when max |actual - expected| <= tol; prints both on failure.
template <typename A, typename B>
::testing::AssertionResult near(const Eigen::MatrixBase<A>& actual,
                                const Eigen::MatrixBase<B>& expected, double tol) {
  const double err = max_abs_diff(actual, expected);
  if (err <= tol) return ::testing::AssertionSuccess();
  const Eigen::IOFormat fmt(Eigen::FullPrecision, 0, ", ", "\n", "[", "]");
  return ::testing::AssertionFailure()
         << "max abs difference " << err << " > " << tol << "\nactual:\n"
         << actual.format(fmt) << "\nexpected:\n"
         << expected.format(fmt);
}

/// Relative form: max |actual - expected| <= rel * max(1, max |expected|).
template <typename A, typename B>
::testing::AssertionResult near_rel(const Eigen::MatrixBase<A>& actual,
                                    const Eigen::MatrixBase<B>& expected, double rel) {
  return near(actual, expected, rel * std::max(1.0, expected.cwiseAbs().maxCoeff()));
}

/// Central differences of f : R^N -> R^M at 0: column k = (f(h e_k) - f(-h e_k)) / 2h.
/// Truncation error O(h^2), rounding error O(eps / h): ~1e-10 for h = 1e-6.
template <int M, int N, typename F>
Eigen::Matrix<double, M, N> central_difference(F&& f, double h = 1e-6) {
  Eigen::Matrix<double, M, N> J;
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> d = Eigen::Matrix<double, N, 1>::Zero();
    d[k] = h;
    const Eigen::Matrix<double, M, 1> plus = f(d);
    const Eigen::Matrix<double, M, 1> minus = f(-d);
    J.col(k) = (plus - minus) / (2.0 * h);
  }
  return J;
}

/// Finite-difference step and tolerance for the Jacobian tests: with h = 1e-6 the error is
/// ~1e-10 (rounding) + ~1e-12 (truncation) times the entries' scale; 1e-7 leaves margin.
inline constexpr double kFdStep = 1e-6;
inline constexpr double kFdTol = 1e-7;

/// A round trip is a handful of operations on numbers up to ~10 (SE3 translations), each off
/// by an ulp or two; 1e-12 (~5000 eps) is tight enough to catch a lost digit and loose enough
/// to be stable.
inline constexpr double kRoundTrip = 1e-12;
/// The closed forms against long-double series: they must hold to a few ulps at every angle,
/// including just either side of the series/closed-form switches.
inline constexpr double kVsSeries = 1e-13;

using Matrix3ld = Eigen::Matrix<long double, 3, 3>;
using Matrix4ld = Eigen::Matrix<long double, 4, 4>;
using Matrix6ld = Eigen::Matrix<long double, 6, 6>;

inline Matrix3ld hat_ld(const Eigen::Vector3d& w) {
  Matrix3ld W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return W;
}

namespace detail {
// Plain row-major long-double matrices: the series below multiply ~30 matrices per sample,
// and Eigen's expression templates in a Debug build would make that the whole test time.
template <int N>
using LdArray = std::array<long double, static_cast<std::size_t>(N* N)>;

template <int N>
LdArray<N> to_array(const Eigen::Matrix<long double, N, N>& m) {
  LdArray<N> a{};
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = 0; j < N; ++j)
      a[i * N + j] = m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
  return a;
}

template <int N>
Eigen::Matrix<long double, N, N> from_array(const LdArray<N>& a) {
  Eigen::Matrix<long double, N, N> m;
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = 0; j < N; ++j)
      m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = a[i * N + j];
  return m;
}

template <int N>
LdArray<N> identity() {
  LdArray<N> a{};
  for (std::size_t i = 0; i < N; ++i) a[i * N + i] = 1;
  return a;
}

/// x * y / divisor.
template <int N>
LdArray<N> multiply(const LdArray<N>& x, const LdArray<N>& y, long double divisor) {
  LdArray<N> z{};
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t k = 0; k < N; ++k) {
      const long double xik = x[i * N + k] / divisor;
      if (xik == 0) continue;
      for (std::size_t j = 0; j < N; ++j) z[i * N + j] += xik * y[k * N + j];
    }
  return z;
}

template <int N>
long double max_abs(const LdArray<N>& a) {
  long double m = 0;
  for (const long double v : a) m = std::max(m, std::fabs(v));
  return m;
}

template <int N>
void add_to(LdArray<N>& sum, const LdArray<N>& term) {
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += term[i];
}
}  // namespace detail

/// sum_n A^n / (n+1)!: the left Jacobian of a Lie group whose ad (or hat, for SO3) is A.
/// Converges for every A; in long double it is a reference ~1e-18 accurate for |A| <~ 10.
template <int N>
Eigen::Matrix<long double, N, N> series_left_jacobian(const Eigen::Matrix<long double, N, N>& A) {
  const detail::LdArray<N> a = detail::to_array<N>(A);
  detail::LdArray<N> term = detail::identity<N>();
  detail::LdArray<N> sum = term;
  for (int n = 1; n < 100; ++n) {
    term = detail::multiply<N>(term, a, static_cast<long double>(n + 1));
    detail::add_to<N>(sum, term);
    // Terms fall factorially once n > |A|; stop when they no longer reach the last digit.
    if (n > 4 && detail::max_abs<N>(term) < 1e-22L * detail::max_abs<N>(sum)) break;
  }
  return detail::from_array<N>(sum);
}

/// exp(A) by scaling and squaring of the Taylor series, in long double: an implementation
/// independent of the closed forms under test.
template <int N>
Eigen::Matrix<long double, N, N> series_exp(const Eigen::Matrix<long double, N, N>& A) {
  int squarings = 0;
  long double norm = A.cwiseAbs().rowwise().sum().maxCoeff();
  while (norm > 0.25L) {
    norm /= 2;
    ++squarings;
  }
  const detail::LdArray<N> b = detail::to_array<N>(A / std::ldexp(1.0L, squarings));
  detail::LdArray<N> term = detail::identity<N>();
  detail::LdArray<N> sum = term;
  for (int n = 1; n < 30; ++n) {
    term = detail::multiply<N>(term, b, static_cast<long double>(n));
    detail::add_to<N>(sum, term);
    if (detail::max_abs<N>(term) < 1e-22L) break;  // |sum| >= 1 - |B| > 0.7
  }
  for (int i = 0; i < squarings; ++i) sum = detail::multiply<N>(sum, sum, 1.0L);
  return detail::from_array<N>(sum);
}

/// ad of an SE3 twist [v, w]: [[w^, v^], [0, w^]], so Ad(exp(xi)) = exp(ad(xi)).
inline Matrix6ld ad_ld(const Eigen::Matrix<double, 6, 1>& xi) {
  Matrix6ld A = Matrix6ld::Zero();
  A.topLeftCorner<3, 3>() = hat_ld(xi.tail<3>());
  A.bottomRightCorner<3, 3>() = hat_ld(xi.tail<3>());
  A.topRightCorner<3, 3>() = hat_ld(xi.head<3>());
  return A;
}

}  // namespace kestrel::test
