// Property tests of SO3 (so3.hpp): exp/log, inverse, composition, adjoint and the left/right
// Jacobians over random rotations (1000 of generic angle, 200 in each special range: ~0, the
// series switches, pi, beyond pi, 2 pi), plus exact half turns.
#include <gtest/gtest.h>

#include <cmath>

#include "geometry_checks.hpp"
#include "geometry_samples.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel {
namespace {

using test::central_difference;
using test::GeometrySampler;
using test::kFdStep;
using test::kFdTol;
using test::kRoundTrip;
using test::kSamples;
using test::kVsSeries;
using test::near;
using test::near_rel;

Eigen::Matrix3d series_exp(const Eigen::Vector3d& w) {
  return test::series_exp<3>(test::hat_ld(w)).cast<double>();
}
Eigen::Matrix3d series_left_jacobian(const Eigen::Vector3d& w) {
  return test::series_left_jacobian<3>(test::hat_ld(w)).cast<double>();
}
Eigen::Matrix3d series_left_jacobian_inverse(const Eigen::Vector3d& w) {
  return test::series_left_jacobian<3>(test::hat_ld(w)).inverse().cast<double>();
}

// Rotation angle between two rotations, robust to the quaternion sign.
double distance(const SO3& a, const SO3& b) { return (a.inverse() * b).angle(); }

/// Rotation vectors of every angle exp accepts: [0, 2 pi + 1e-6].
class So3ExpRanges : public ::testing::TestWithParam<test::AngleRange> {};
/// Rotation vectors with angles in log's range [0, pi).
class So3LogRanges : public ::testing::TestWithParam<test::AngleRange> {};
/// Angles in [0, pi - 1e-3]: log is smooth there (it jumps at pi, where w and -w meet).
class So3SmoothLogRanges : public ::testing::TestWithParam<test::AngleRange> {};

INSTANTIATE_TEST_SUITE_P(Angles, So3ExpRanges, ::testing::ValuesIn(test::kExpRanges),
                         test::range_name);
INSTANTIATE_TEST_SUITE_P(Angles, So3LogRanges, ::testing::ValuesIn(test::kLogRanges),
                         test::range_name);
INSTANTIATE_TEST_SUITE_P(Angles, So3SmoothLogRanges,
                         ::testing::Values(test::kTiny, test::kSmall, test::kSwitch,
                                           test::kGeneric),
                         test::range_name);

TEST(So3, HatIsTheCrossProductAndVeeInvertsIt) {
  GeometrySampler rng(1);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d w = rng.vector(10.0);
    const Eigen::Vector3d p = rng.vector(10.0);
    const Eigen::Matrix3d W = SO3::hat(w);
    ASSERT_TRUE(near(W * p, w.cross(p), 1e-12)) << "sample " << i;
    ASSERT_TRUE(near(W.transpose(), -W, 0.0)) << "sample " << i;
    ASSERT_TRUE(near(SO3::vee(W), w, 0.0)) << "sample " << i;
  }
}

TEST(So3, IdentityIsExactAtZero) {
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  EXPECT_TRUE(near(SO3::exp(zero).matrix(), Eigen::Matrix3d::Identity(), 0.0));
  EXPECT_TRUE(near(SO3().log(), zero, 0.0));
  EXPECT_EQ(SO3().angle(), 0.0);
  EXPECT_TRUE(near(SO3::left_jacobian(zero), Eigen::Matrix3d::Identity(), 0.0));
  EXPECT_TRUE(near(SO3::left_jacobian_inverse(zero), Eigen::Matrix3d::Identity(), 0.0));
  EXPECT_TRUE(near(SO3::right_jacobian(zero), Eigen::Matrix3d::Identity(), 0.0));
}

TEST_P(So3ExpRanges, ExpIsTheMatrixExponential) {
  GeometrySampler rng(test::seed_for("exp", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 R = SO3::exp(w);
    const Eigen::Matrix3d M = R.matrix();
    ASSERT_TRUE(near(M, series_exp(w), kVsSeries)) << "sample " << i << " w " << w.transpose();
    ASSERT_TRUE(near(M * M.transpose(), Eigen::Matrix3d::Identity(), kRoundTrip));
    ASSERT_NEAR(M.determinant(), 1.0, kRoundTrip);
    ASSERT_NEAR(R.unit_quaternion().norm(), 1.0, 1e-15);
    ASSERT_GE(R.unit_quaternion().w(), 0.0);
  }
}

TEST_P(So3ExpRanges, LogReturnsTheEquivalentRotationVectorWithAngleAtMostPi) {
  GeometrySampler rng(test::seed_for("log_range", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 R = SO3::exp(w);
    const Eigen::Vector3d l = R.log();
    ASSERT_LE(l.norm(), kPi) << "sample " << i << " w " << w.transpose();
    ASSERT_NEAR(l.norm(), R.angle(), 1e-15);
    // An angle beyond pi comes back as 2 pi - angle about the opposite axis.
    const double theta = w.norm();
    const Eigen::Vector3d expected =
        theta <= kPi ? w : Eigen::Vector3d(w - (2.0 * kPi / theta) * w);
    ASSERT_TRUE(near(l, expected, kRoundTrip)) << "sample " << i << " w " << w.transpose();
    ASSERT_TRUE(near(SO3::exp(l).matrix(), R.matrix(), kRoundTrip)) << "sample " << i;
  }
}

TEST_P(So3LogRanges, LogInvertsExpToRelativePrecision) {
  // Relative, not absolute: at 1e-10 rad an absolute 1e-12 would accept a wrong answer.
  GeometrySampler rng(test::seed_for("log_exp", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const Eigen::Vector3d l = SO3::exp(w).log();
    ASSERT_LE((l - w).norm(), kRoundTrip * w.norm())
        << "sample " << i << " w " << w.transpose() << " log " << l.transpose();
  }
}

TEST_P(So3LogRanges, ExpInvertsLog) {
  GeometrySampler rng(test::seed_for("exp_log", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    // Rotations of the range's angles about random axes, applied to Haar-random ones so that
    // the quaternion's components are all populated.
    const SO3 R = SO3(rng.unit_quaternion());
    const SO3 X = SO3::exp(rng.rotation_vector(GetParam()));
    for (const SO3& Y : {R, X}) {
      const SO3 back = SO3::exp(Y.log());
      ASSERT_TRUE(near(back.matrix(), Y.matrix(), kRoundTrip)) << "sample " << i;
      ASSERT_TRUE(near(back.unit_quaternion().coeffs(), Y.unit_quaternion().coeffs(), kRoundTrip))
          << "sample " << i;
    }
  }
}

TEST(So3, LogOfAHalfTurnHasAnglePiAndExpRecoversIt) {
  GeometrySampler rng(2);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d u = rng.unit_vector();
    // Through exp: the quaternion's scalar is cos(pi/2) ~ 6e-17.
    const SO3 A = SO3::exp(kPi * u);
    ASSERT_NEAR(A.log().norm(), kPi, 1e-15) << "sample " << i;
    ASSERT_NEAR(A.angle(), kPi, 1e-15);
    // |pi u| rounds to either side of pi, so the quaternion's scalar has either sign and log
    // returns pi u or -pi u: the same rotation.
    ASSERT_LT(A.log().normalized().cross(u).norm(), 1e-14) << "sample " << i;
    ASSERT_TRUE(near(SO3::exp(A.log()).matrix(), A.matrix(), kRoundTrip));

    // Through from_matrix of the exact half turn 2 u u^T - I: the scalar is exactly 0 (or a
    // rounding error of either sign), the axis is +u or -u.
    const Eigen::Matrix3d M = 2.0 * u * u.transpose() - Eigen::Matrix3d::Identity();
    const SO3 B = SO3::from_matrix(M);
    ASSERT_TRUE(near(B.matrix(), M, kRoundTrip)) << "sample " << i << " u " << u.transpose();
    const Eigen::Vector3d l = B.log();
    ASSERT_NEAR(l.norm(), kPi, 1e-15) << "sample " << i << " u " << u.transpose();
    ASSERT_LT(l.normalized().cross(u).norm(), 1e-14) << "sample " << i;
    ASSERT_TRUE(near(SO3::exp(l).matrix(), M, kRoundTrip)) << "sample " << i;
  }
}

TEST(So3, ExpNearTwoPiIsTheSmallRotationTheOtherWay) {
  GeometrySampler rng(3);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d u = rng.unit_vector();
    const double eps = rng.uniform(-1e-6, 1e-6);
    const SO3 R = SO3::exp((2.0 * kPi + eps) * u);
    // The rotation is eps about u; only the absolute angle is known to ~1e-15 after
    // 2 pi + eps is rounded.
    ASSERT_TRUE(near(R.matrix(), SO3::exp(eps * u).matrix(), 1e-14)) << "sample " << i;
    ASSERT_TRUE(near(R.log(), eps * u, 1e-14)) << "sample " << i;
  }
  EXPECT_TRUE(near(SO3::exp(Eigen::Vector3d(0, 0, 2.0 * kPi)).matrix(), Eigen::Matrix3d::Identity(),
                   1e-15));
}

TEST_P(So3ExpRanges, InverseAndCompositionAgreeWithMatrices) {
  GeometrySampler rng(test::seed_for("compose", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SO3 A = SO3::exp(rng.rotation_vector(GetParam()));
    const SO3 B(rng.unit_quaternion());
    const SO3 C = SO3::exp(rng.rotation_vector(GetParam()));
    const Eigen::Vector3d p = rng.vector(10.0);
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    ASSERT_TRUE(near((A * A.inverse()).matrix(), I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near((A.inverse() * A).matrix(), I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(A.inverse().matrix(), A.matrix().transpose(), kRoundTrip));
    ASSERT_LT(distance((A * B) * C, A * (B * C)), kRoundTrip) << "sample " << i;
    ASSERT_TRUE(near((A * B).matrix(), A.matrix() * B.matrix(), kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(A * p, A.matrix() * p, 10 * kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near((A * B) * p, A * (B * p), 10 * kRoundTrip)) << "sample " << i;
  }
}

TEST_P(So3ExpRanges, AdjointCarriesATwistThroughTheRotation) {
  // X exp(w) X^-1 = exp(Ad_X w) with Ad_X = R_X, and R w^ R^T = (R w)^.
  GeometrySampler rng(test::seed_for("adjoint", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SO3 X(rng.unit_quaternion());
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 lhs = X * SO3::exp(w) * X.inverse();
    const SO3 rhs = SO3::exp(X.adjoint() * w);
    ASSERT_TRUE(near(lhs.matrix(), rhs.matrix(), kRoundTrip)) << "sample " << i;
    const Eigen::Matrix3d R = X.matrix();
    ASSERT_TRUE(near(R * SO3::hat(w) * R.transpose(), SO3::hat(X.adjoint() * w), kRoundTrip));
  }
}

TEST_P(So3ExpRanges, LeftJacobianMatchesFiniteDifferences) {
  // exp(w + d) ~= exp(J_l(w) d) exp(w): J_l = d log(exp(w + d) exp(w)^-1) / dd at d = 0.
  GeometrySampler rng(test::seed_for("jl_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 R_inv = SO3::exp(w).inverse();
    const Eigen::Matrix3d numeric = central_difference<3, 3>(
        [&](const Eigen::Vector3d& d) { return (SO3::exp(w + d) * R_inv).log(); }, kFdStep);
    ASSERT_TRUE(near_rel(SO3::left_jacobian(w), numeric, kFdTol))
        << "sample " << i << " w " << w.transpose();
  }
}

TEST_P(So3ExpRanges, RightJacobianMatchesFiniteDifferences) {
  // exp(w + d) ~= exp(w) exp(J_r(w) d).
  GeometrySampler rng(test::seed_for("jr_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 R_inv = SO3::exp(w).inverse();
    const Eigen::Matrix3d numeric = central_difference<3, 3>(
        [&](const Eigen::Vector3d& d) { return (R_inv * SO3::exp(w + d)).log(); }, kFdStep);
    ASSERT_TRUE(near_rel(SO3::right_jacobian(w), numeric, kFdTol))
        << "sample " << i << " w " << w.transpose();
  }
}

TEST_P(So3ExpRanges, LeftJacobianMatchesItsSeries) {
  // J_l = sum w^n / (n+1)! (the README's erratum of eq. 3.14), to a few ulps at every angle.
  GeometrySampler rng(test::seed_for("jl_series", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    ASSERT_TRUE(near(SO3::left_jacobian(w), series_left_jacobian(w), kVsSeries))
        << "sample " << i << " w " << w.transpose();
    ASSERT_TRUE(near(SO3::right_jacobian(w), series_left_jacobian(-w), kVsSeries));
  }
}

TEST_P(So3ExpRanges, ExpAndJacobianProductEqualExpAndTheJacobianTimesV) {
  // The shared-sine form SE3::exp uses: the same rotation as exp() and the same J_l v as the
  // series, to a few ulps at every angle.
  GeometrySampler rng(test::seed_for("exp_jv", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const Eigen::Vector3d v = rng.vector(2.0);
    const So3ExpAndJacobianProduct e = SO3::exp_and_left_jacobian_times(w, v);
    ASSERT_TRUE(near(e.rotation.matrix(), SO3::exp(w).matrix(), kVsSeries)) << "sample " << i;
    ASSERT_TRUE(
        near(e.jacobian_times_v, Eigen::Vector3d(series_left_jacobian(w) * v), kVsSeries * 2.0))
        << "sample " << i << " w " << w.transpose();
  }
}

TEST_P(So3LogRanges, JacobianInversesMatchTheSeriesAndInvert) {
  GeometrySampler rng(test::seed_for("jl_inv", GetParam()));
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const Eigen::Matrix3d Jl_inv = SO3::left_jacobian_inverse(w);
    ASSERT_TRUE(near(Jl_inv, series_left_jacobian_inverse(w), kVsSeries))
        << "sample " << i << " w " << w.transpose() << " |w| " << w.norm();
    ASSERT_TRUE(near(SO3::left_jacobian(w) * Jl_inv, I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(Jl_inv * SO3::left_jacobian(w), I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(SO3::right_jacobian(w) * SO3::right_jacobian_inverse(w), I, kRoundTrip))
        << "sample " << i;
  }
}

TEST_P(So3SmoothLogRanges, JacobianInversesAreTheDerivativesOfLog) {
  // d log(exp(d) R) / dd = J_l^-1(log R); d log(R exp(d)) / dd = J_r^-1(log R).
  GeometrySampler rng(test::seed_for("jinv_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Eigen::Vector3d w = rng.rotation_vector(GetParam());
    const SO3 R = SO3::exp(w);
    const Eigen::Matrix3d d_log_left = central_difference<3, 3>(
        [&](const Eigen::Vector3d& d) { return (SO3::exp(d) * R).log(); }, kFdStep);
    const Eigen::Matrix3d d_log_right = central_difference<3, 3>(
        [&](const Eigen::Vector3d& d) { return (R * SO3::exp(d)).log(); }, kFdStep);
    ASSERT_TRUE(near_rel(SO3::left_jacobian_inverse(R.log()), d_log_left, kFdTol))
        << "sample " << i << " w " << w.transpose();
    ASSERT_TRUE(near_rel(SO3::right_jacobian_inverse(R.log()), d_log_right, kFdTol))
        << "sample " << i << " w " << w.transpose();
  }
}

TEST(So3, QuaternionConstructorNormalisesAndPicksNonNegativeScalar) {
  GeometrySampler rng(4);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Quaterniond q = rng.unit_quaternion();
    const double scale = rng.uniform(1e-3, 1e3) * (i % 2 == 0 ? 1.0 : -1.0);
    const Eigen::Quaterniond scaled(scale * q.w(), scale * q.x(), scale * q.y(), scale * q.z());
    const SO3 R(scaled);
    ASSERT_NEAR(R.unit_quaternion().norm(), 1.0, 1e-15);
    ASSERT_GE(R.unit_quaternion().w(), 0.0);
    ASSERT_TRUE(near(R.matrix(), q.toRotationMatrix(), kRoundTrip)) << "sample " << i;
  }
}

TEST(So3, FromMatrixRecoversTheRotation) {
  GeometrySampler rng(5);
  for (int i = 0; i < kSamples; ++i) {
    const SO3 R(rng.unit_quaternion());
    const SO3 back = SO3::from_matrix(R.matrix());
    ASSERT_TRUE(near(back.matrix(), R.matrix(), kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(back.unit_quaternion().coeffs(), R.unit_quaternion().coeffs(), kRoundTrip))
        << "sample " << i;
    // A matrix off SO(3) by ~1e-6 (a rounded calibration file) still gives a rotation close
    // to it.
    Eigen::Matrix3d noise;
    noise << rng.vector(1e-6), rng.vector(1e-6), rng.vector(1e-6);
    const Eigen::Matrix3d noisy = R.matrix() + noise;
    const SO3 fixed = SO3::from_matrix(noisy);
    ASSERT_NEAR(fixed.unit_quaternion().norm(), 1.0, 1e-15);
    ASSERT_LT(distance(fixed, R), 1e-5) << "sample " << i;
  }
}

}  // namespace
}  // namespace kestrel
