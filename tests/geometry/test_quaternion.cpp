// The thesis' quaternion formulas (quaternion.hpp, appendices A and B) against Eigen's
// Hamilton quaternions, and one test per erratum of shared/reference/README.md that the
// misprinted formula fails (each such test also runs the misprint to prove it).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <utility>

#include "geometry_checks.hpp"
#include "geometry_samples.hpp"
#include "kestrel/geometry/quaternion.hpp"

namespace kestrel {
namespace {

using quat::Quat;
using test::GeometrySampler;
using test::kSamples;
using test::near;

constexpr double kTol = 1e-14;  // a few ulps of O(1) products

Eigen::Quaterniond to_eigen(const Quat& q) { return {q[0], q[1], q[2], q[3]}; }
Quat from_eigen(const Eigen::Quaterniond& q) { return {q.w(), q.x(), q.y(), q.z()}; }

/// A quaternion with components N(0, 1) scaled by a random factor in [0.1, 10]: not unit.
Quat random_quat(GeometrySampler& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Quat q{n(rng.engine()), n(rng.engine()), n(rng.engine()), n(rng.engine())};
  return rng.uniform(0.1, 10.0) * q.normalized();
}

Quat random_unit_quat(GeometrySampler& rng) { return from_eigen(rng.unit_quaternion()); }

/// q and -q are the same rotation.
double sign_free_distance(const Quat& a, const Quat& b) {
  return std::min((a - b).cwiseAbs().maxCoeff(), (a + b).cwiseAbs().maxCoeff());
}

// ---- The misprints, verbatim from the thesis, to show that each erratum test rejects them.

Quat misprinted_multiply_a6(const Quat& q1, const Quat& q2) {
  Quat q = quat::multiply(q1, q2);
  // Eq. A.6, last row as printed: s1 c2 - a1 b2 - b1 a2 + c1 s2.
  q[3] = q1[0] * q2[3] - q1[1] * q2[2] - q1[2] * q2[1] + q1[3] * q2[0];
  return q;
}

Quat misprinted_inverse_a8(const Quat& q) { return quat::conjugate(q) / q.norm(); }

Eigen::Matrix3d misprinted_matrix_b1(const Quat& q) {
  Eigen::Matrix3d R = quat::to_rotation_matrix(q);
  R(2, 1) = 2.0 * q[0] * q[1];  // eq. B.1 as printed drops + 2 b c
  return R;
}

/// Eqs. B.2 and B.3 as printed: the products a c, a b, b c from differences, not sums.
Quat misprinted_from_matrix_b3(const Eigen::Matrix3d& R) {
  const double tr = R.trace();
  const Eigen::Vector4d sq{1.0 + tr, 1.0 + 2 * R(0, 0) - tr, 1.0 + 2 * R(1, 1) - tr,
                           1.0 + 2 * R(2, 2) - tr};
  Eigen::Index k = 0;
  sq.maxCoeff(&k);
  const double sa = R(2, 1) - R(1, 2), sb = R(0, 2) - R(2, 0), sc = R(1, 0) - R(0, 1);
  const double ac = R(0, 2) - R(2, 0), ab = R(1, 0) - R(0, 1), bc = R(2, 1) - R(1, 2);
  const double big = 0.5 * std::sqrt(sq[k]);
  const double f = 0.25 / big;
  Quat q;
  switch (k) {
    case 0:
      q = {big, sa * f, sb * f, sc * f};
      break;
    case 1:
      q = {sa * f, big, ab * f, ac * f};
      break;
    case 2:
      q = {sb * f, ab * f, big, bc * f};
      break;
    default:
      q = {sc * f, ac * f, bc * f, big};
      break;
  }
  return q;
}

// ---- Appendix A.

TEST(Quaternion, MultiplyIsEigensHamiltonProduct) {
  GeometrySampler rng(21);
  for (int i = 0; i < kSamples; ++i) {
    const Quat q1 = random_quat(rng);
    const Quat q2 = random_quat(rng);
    const Quat expected = from_eigen(to_eigen(q1) * to_eigen(q2));
    ASSERT_TRUE(near(quat::multiply(q1, q2), expected, kTol * 100.0))  // |q1 q2| up to 100
        << "sample " << i;
  }
}

TEST(QuaternionErrata, A6KComponentIsS1C2PlusA1B2MinusB1A2PlusC1S2) {
  // i j = k, j k = i, k i = j (eq. A.2); as printed, A.6 gives i j = -k.
  const Quat one{1, 0, 0, 0}, i{0, 1, 0, 0}, j{0, 0, 1, 0}, k{0, 0, 0, 1};
  EXPECT_TRUE(near(quat::multiply(i, j), k, 0.0));
  EXPECT_TRUE(near(quat::multiply(j, k), i, 0.0));
  EXPECT_TRUE(near(quat::multiply(k, i), j, 0.0));
  EXPECT_TRUE(near(quat::multiply(j, i), Quat(-k), 0.0));
  EXPECT_TRUE(near(quat::multiply(i, i), Quat(-one), 0.0));
  EXPECT_TRUE(near(quat::multiply(quat::multiply(i, j), k), Quat(-one), 0.0));  // ijk = -1
  EXPECT_FALSE(near(misprinted_multiply_a6(i, j), k, 0.5)) << "the misprint should fail";

  // And over random quaternions, where the misprint is off by 2 a1 b2.
  GeometrySampler rng(22);
  for (int s = 0; s < kSamples; ++s) {
    const Quat q1 = random_unit_quat(rng), q2 = random_unit_quat(rng);
    const Quat expected = from_eigen(to_eigen(q1) * to_eigen(q2));
    ASSERT_NEAR(quat::multiply(q1, q2)[3], expected[3], kTol) << "sample " << s;
    ASSERT_NEAR(misprinted_multiply_a6(q1, q2)[3] - expected[3], -2.0 * q1[1] * q2[2], kTol);
  }
}

TEST(Quaternion, ConjugateMatchesEigenAndReversesProducts) {
  GeometrySampler rng(23);
  for (int i = 0; i < kSamples; ++i) {
    const Quat q1 = random_quat(rng), q2 = random_quat(rng);
    ASSERT_TRUE(near(quat::conjugate(q1), from_eigen(to_eigen(q1).conjugate()), 0.0));
    // (q1 q2)* = q2* q1*
    ASSERT_TRUE(near(quat::conjugate(quat::multiply(q1, q2)),
                     quat::multiply(quat::conjugate(q2), quat::conjugate(q1)), kTol * 100.0));
    // q q* = |q|^2
    const Quat n2 = quat::multiply(q1, quat::conjugate(q1));
    ASSERT_NEAR(n2[0], q1.squaredNorm(), kTol * 100.0);
    ASSERT_TRUE(near(n2.tail<3>(), Eigen::Vector3d::Zero(), kTol * 100.0));
  }
}

TEST(QuaternionErrata, A8InverseDividesByTheSquaredNorm) {
  // Non-unit quaternions: as printed (divided by |q|), q q^-1 = |q| instead of 1.
  GeometrySampler rng(24);
  const Quat one{1, 0, 0, 0};
  for (int i = 0; i < kSamples; ++i) {
    const Quat q = random_quat(rng);
    const Quat q_inv = quat::inverse(q);
    ASSERT_TRUE(near(quat::multiply(q, q_inv), one, kTol)) << "sample " << i << " |q| " << q.norm();
    ASSERT_TRUE(near(quat::multiply(q_inv, q), one, kTol)) << "sample " << i;
    ASSERT_TRUE(near(q_inv, from_eigen(to_eigen(q).inverse()), kTol * 10.0)) << "sample " << i;
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      ASSERT_FALSE(near(quat::multiply(q, misprinted_inverse_a8(q)), one, 1e-4))
          << "the misprint should fail, |q| " << q.norm();
    }
  }
}

TEST(Quaternion, InverseOfZeroThrows) {
  EXPECT_THROW((void)quat::inverse(Quat::Zero()), std::invalid_argument);
  // The smallest normal numbers still have an inverse (|q|^2 underflows only below ~1e-154).
  EXPECT_NO_THROW((void)quat::inverse(Quat(1e-100, 0, 0, 0)));
}

TEST(Quaternion, RotateIsRTimesP) {
  GeometrySampler rng(25);
  for (int i = 0; i < kSamples; ++i) {
    const Quat q = random_unit_quat(rng);
    const Eigen::Vector3d p = rng.vector(10.0);
    const Eigen::Vector3d expected = to_eigen(q).toRotationMatrix() * p;
    ASSERT_TRUE(near(quat::rotate(q, p), expected, 1e-13)) << "sample " << i;
    ASSERT_TRUE(near(quat::rotate(q, p), quat::to_rotation_matrix(q) * p, 1e-13));
    // The rotation vector's own axis is fixed, and q and -q rotate alike.
    ASSERT_TRUE(near(quat::rotate(q, q.tail<3>()), q.tail<3>(), 1e-15));
    ASSERT_TRUE(near(quat::rotate(Quat(-q), p), quat::rotate(q, p), 1e-13));
  }
  // A quarter turn about z takes x to y.
  const double h = std::sqrt(0.5);
  EXPECT_TRUE(near(quat::rotate(Quat(h, 0, 0, h), Eigen::Vector3d::UnitX()),
                   Eigen::Vector3d::UnitY(), 1e-15));
}

// ---- Appendix B.

TEST(Quaternion, ToRotationMatrixMatchesEigen) {
  GeometrySampler rng(26);
  for (int i = 0; i < kSamples; ++i) {
    const Quat q = random_unit_quat(rng);
    const Eigen::Matrix3d R = quat::to_rotation_matrix(q);
    ASSERT_TRUE(near(R, to_eigen(q).toRotationMatrix(), kTol)) << "sample " << i;
    ASSERT_TRUE(near(R * R.transpose(), Eigen::Matrix3d::Identity(), kTol)) << "sample " << i;
    ASSERT_NEAR(R.determinant(), 1.0, kTol);
  }
}

TEST(QuaternionErrata, B1Entry32Is2SAPlus2BC) {
  // q = (1/2)(1, 1, 1, 1): a third of a turn about (1, 1, 1), which cycles the axes, so
  // R = [[0, 0, 1], [1, 0, 0], [0, 1, 0]] and r32 = 2 s a + 2 b c = 1; as printed, 1/2.
  const Quat q{0.5, 0.5, 0.5, 0.5};
  Eigen::Matrix3d cycle;
  cycle << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  EXPECT_TRUE(near(quat::to_rotation_matrix(q), cycle, 0.0));
  EXPECT_DOUBLE_EQ(quat::to_rotation_matrix(q)(2, 1), 1.0);
  EXPECT_FALSE(near(misprinted_matrix_b1(q), cycle, 0.1)) << "the misprint should fail";

  // Over random rotations: the corrected matrix is orthonormal; the misprint is not.
  GeometrySampler rng(27);
  for (int i = 0; i < kSamples; ++i) {
    const Quat u = random_unit_quat(rng);
    const Eigen::Matrix3d R = quat::to_rotation_matrix(u);
    ASSERT_NEAR(R(2, 1), 2.0 * (u[0] * u[1] + u[2] * u[3]), kTol);
    ASSERT_TRUE(near(R * R.transpose(), Eigen::Matrix3d::Identity(), kTol)) << "sample " << i;
    const Eigen::Matrix3d M = misprinted_matrix_b1(u);
    if (std::abs(u[2] * u[3]) > 1e-3) {
      ASSERT_FALSE(near(M * M.transpose(), Eigen::Matrix3d::Identity(), 1e-4)) << "sample " << i;
    }
  }
}

TEST(Quaternion, FromRotationMatrixRoundTrips) {
  GeometrySampler rng(28);
  for (int i = 0; i < kSamples; ++i) {
    const Quat q = random_unit_quat(rng);
    const Eigen::Matrix3d R = quat::to_rotation_matrix(q);
    const Quat back = quat::from_rotation_matrix(R);
    ASSERT_GE(back[0], 0.0) << "sample " << i;
    ASSERT_NEAR(back.norm(), 1.0, 1e-15);
    ASSERT_LT(sign_free_distance(back, q), kTol) << "sample " << i;
    ASSERT_LT(sign_free_distance(back, from_eigen(Eigen::Quaterniond(R))), kTol);
    ASSERT_TRUE(near(quat::to_rotation_matrix(back), R, kTol)) << "sample " << i;
  }
}

TEST(Quaternion, FromRotationMatrixAtAHalfTurn) {
  // s = 0: the diagonal gives no sign and the trace formula alone would divide by zero.
  GeometrySampler rng(29);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d u = rng.unit_vector();
    const Eigen::Matrix3d R = 2.0 * u * u.transpose() - Eigen::Matrix3d::Identity();
    const Quat q = quat::from_rotation_matrix(R);
    ASSERT_LT(sign_free_distance(q, Quat(0.0, u.x(), u.y(), u.z())), kTol)
        << "sample " << i << " u " << u.transpose();
    ASSERT_TRUE(near(quat::to_rotation_matrix(q), R, kTol)) << "sample " << i;
    // And through exp of an angle of exactly pi (the matrix has sin(pi) ~ 1e-16 residues).
    const Eigen::Matrix3d Rpi = Eigen::AngleAxisd(kPi, u).toRotationMatrix();
    ASSERT_TRUE(near(quat::to_rotation_matrix(quat::from_rotation_matrix(Rpi)), Rpi, kTol));
  }
}

TEST(QuaternionErrata, B3ProductsOfTheVectorPartAreSums) {
  // Rotations in which each of s, a, b, c in turn is the largest component, so that every
  // branch of the largest-component method runs; with a, b or c largest the other two vector
  // components come from the products a b, a c, b c that eq. B.3 misprints as differences.
  GeometrySampler rng(30);
  for (int largest = 0; largest < 4; ++largest) {
    for (int i = 0; i < kSamples / 4; ++i) {
      Quat q = random_unit_quat(rng);
      Eigen::Index k = 0;
      q.cwiseAbs().maxCoeff(&k);
      std::swap(q[k], q[largest]);
      if (q[0] < 0) q = -q;
      const Eigen::Matrix3d R = quat::to_rotation_matrix(q);
      const Quat back = quat::from_rotation_matrix(R);
      ASSERT_LT(sign_free_distance(back, q), kTol) << "largest " << largest << " sample " << i;
      if (largest > 0) {
        ASSERT_GT(sign_free_distance(misprinted_from_matrix_b3(R), q), 1e-6)
            << "the misprint should fail; largest " << largest << " sample " << i;
      }
    }
  }
  // One by hand: a half turn about (1, 1, 0)/sqrt 2 has q = (0, h, h, 0), a b = 1/2, and
  // r21 = r12 = 1, so the printed (r21 - r12)/4 = 0 would lose b altogether.
  const double h = std::sqrt(0.5);
  const Quat q{0.0, h, h, 0.0};
  EXPECT_LT(sign_free_distance(quat::from_rotation_matrix(quat::to_rotation_matrix(q)), q), kTol);
  EXPECT_GT(sign_free_distance(misprinted_from_matrix_b3(quat::to_rotation_matrix(q)), q), 0.5);
}

}  // namespace
}  // namespace kestrel
