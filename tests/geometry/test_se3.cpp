// Property tests of SE3 (se3.hpp), twists [v, w]: exp/log, inverse, composition, adjoint,
// left Jacobian and its inverse, and the derivative of the action on a point, over random
// twists and poses (1000 of generic rotation angle, 200 in each special angle range).
#include <gtest/gtest.h>

#include <cmath>

#include "geometry_checks.hpp"
#include "geometry_samples.hpp"
#include "kestrel/geometry/se3.hpp"

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

// Translations up to 5 m per axis: a few metres is a frame-to-frame motion at most, but the
// coupling terms of the Jacobian scale with |v| and this exercises them.
constexpr double kMaxV = 5.0;

using Matrix34d = Eigen::Matrix<double, 3, 4>;
using Matrix36d = Eigen::Matrix<double, 3, 6>;

Eigen::Matrix4d series_exp(const Vector6d& xi) {
  test::Matrix4ld X = test::Matrix4ld::Zero();
  X.topLeftCorner<3, 3>() = test::hat_ld(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>().cast<long double>();
  return test::series_exp<4>(X).cast<double>();
}

Matrix6d series_left_jacobian(const Vector6d& xi) {
  return test::series_left_jacobian<6>(test::ad_ld(xi)).cast<double>();
}

Matrix6d series_left_jacobian_inverse(const Vector6d& xi) {
  return test::series_left_jacobian<6>(test::ad_ld(xi)).inverse().cast<double>();
}

/// d (exp(d) * q) / dd at d = 0 for a point q: [I, -q^] (twist [v, w], left perturbation).
Matrix36d d_left_action_d_xi(const Eigen::Vector3d& q) {
  Matrix36d J;
  J << Eigen::Matrix3d::Identity(), -SO3::hat(q);
  return J;
}

/// Rotation angles in [0, 2 pi + 1e-6]: exp and the closed forms accept any angle.
class Se3ExpRanges : public ::testing::TestWithParam<test::AngleRange> {};
/// Rotation angles in [0, pi]: log's range, and where the finite-difference tests (six
/// exp/log pairs per sample, the slow ones in a Debug build) matter. SO3's tests cover
/// the finite differences beyond pi.
class Se3LogRanges : public ::testing::TestWithParam<test::AngleRange> {};
/// Angles in [0, pi - 1e-3]: log is smooth there (it jumps at pi, where w and -w meet).
class Se3SmoothLogRanges : public ::testing::TestWithParam<test::AngleRange> {};

INSTANTIATE_TEST_SUITE_P(Angles, Se3ExpRanges, ::testing::ValuesIn(test::kExpRanges),
                         test::range_name);
INSTANTIATE_TEST_SUITE_P(Angles, Se3LogRanges, ::testing::ValuesIn(test::kLogRanges),
                         test::range_name);
INSTANTIATE_TEST_SUITE_P(Angles, Se3SmoothLogRanges,
                         ::testing::Values(test::kTiny, test::kSmall, test::kSwitch,
                                           test::kGeneric),
                         test::range_name);

TEST(Se3, HatVeeRoundTripAndTwistOrderIsTranslationFirst) {
  GeometrySampler rng(11);
  for (int i = 0; i < kSamples; ++i) {
    Vector6d xi;
    xi << rng.vector(10.0), rng.vector(10.0);
    const Eigen::Matrix4d X = SE3::hat(xi);
    ASSERT_TRUE(near(SE3::vee(X), xi, 0.0)) << "sample " << i;
    // [[w^, v], [0, 0]] applied to a homogeneous point: w x p + v.
    const Eigen::Vector3d p = rng.vector(10.0);
    const Eigen::Vector4d Xp = X * p.homogeneous();
    ASSERT_TRUE(near(Xp.head<3>(), xi.tail<3>().cross(p) + xi.head<3>(), 1e-12));
    ASSERT_EQ(Xp[3], 0.0);
  }
  // A pure translation twist moves points, a pure rotation twist turns them (eq. 3.10 erratum).
  Vector6d v_only;
  v_only << 1, 2, 3, 0, 0, 0;
  EXPECT_TRUE(near(SE3::exp(v_only).translation(), Eigen::Vector3d(1, 2, 3), 0.0));
  EXPECT_TRUE(near(SE3::exp(v_only).rotation_matrix(), Eigen::Matrix3d::Identity(), 0.0));
  Vector6d w_only;
  w_only << 0, 0, 0, 0, 0, kPi / 2;
  EXPECT_TRUE(near(SE3::exp(w_only) * Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), 1e-15));
}

TEST_P(Se3ExpRanges, ExpIsTheMatrixExponentialOfTheTwist) {
  GeometrySampler rng(test::seed_for("se3_exp", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const SE3 T = SE3::exp(xi);
    ASSERT_TRUE(near_rel(T.matrix(), series_exp(xi), kVsSeries))
        << "sample " << i << " xi " << xi.transpose();
    ASSERT_TRUE(near(T.matrix3x4(), Matrix34d(T.matrix().topRows<3>()), 0.0));
    ASSERT_TRUE(near(T.rotation_matrix(), T.so3().matrix(), 0.0));
  }
}

TEST_P(Se3LogRanges, LogInvertsExpToRelativePrecision) {
  GeometrySampler rng(test::seed_for("se3_log_exp", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const Vector6d l = SE3::exp(xi).log();
    ASSERT_LE((l.head<3>() - xi.head<3>()).norm(), kRoundTrip * xi.head<3>().norm())
        << "sample " << i << " xi " << xi.transpose() << " log " << l.transpose();
    ASSERT_LE((l.tail<3>() - xi.tail<3>()).norm(), kRoundTrip * xi.tail<3>().norm())
        << "sample " << i << " xi " << xi.transpose() << " log " << l.transpose();
  }
}

TEST_P(Se3LogRanges, ExpInvertsLog) {
  GeometrySampler rng(test::seed_for("se3_exp_log", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SE3 A(SO3(rng.unit_quaternion()), rng.vector(10.0));
    const SE3 B = rng.pose(GetParam(), 10.0);
    for (const SE3& T : {A, B}) {
      ASSERT_TRUE(near_rel(SE3::exp(T.log()).matrix(), T.matrix(), kRoundTrip))
          << "sample " << i << "\n"
          << T.matrix();
    }
  }
}

TEST(Se3, ExpLogRoundTripsThroughAHalfTurn) {
  GeometrySampler rng(12);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d u = rng.unit_vector();
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    M.topLeftCorner<3, 3>() = 2.0 * u * u.transpose() - Eigen::Matrix3d::Identity();
    M.topRightCorner<3, 1>() = rng.vector(10.0);
    const SE3 T = SE3::from_matrix(M);
    ASSERT_TRUE(near_rel(T.matrix(), M, kRoundTrip)) << "sample " << i;
    const Vector6d xi = T.log();
    ASSERT_NEAR(xi.tail<3>().norm(), kPi, 1e-15) << "sample " << i;
    ASSERT_TRUE(near_rel(SE3::exp(xi).matrix(), M, kRoundTrip)) << "sample " << i;
  }
}

TEST_P(Se3ExpRanges, InverseAndCompositionAgreeWithMatrices) {
  GeometrySampler rng(test::seed_for("se3_compose", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SE3 T_a_b = rng.pose(GetParam(), 10.0);
    const SE3 T_b_c(SO3(rng.unit_quaternion()), rng.vector(10.0));
    const SE3 T_c_d = rng.pose(GetParam(), 10.0);
    const Eigen::Vector3d p_c = rng.vector(10.0);
    const Eigen::Matrix4d I = Eigen::Matrix4d::Identity();
    ASSERT_TRUE(near_rel((T_a_b * T_a_b.inverse()).matrix(), I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near_rel((T_a_b.inverse() * T_a_b).matrix(), I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near_rel(T_a_b.inverse().matrix(), T_a_b.matrix().inverse(), kRoundTrip));
    ASSERT_TRUE(near_rel(((T_a_b * T_b_c) * T_c_d).matrix(), (T_a_b * (T_b_c * T_c_d)).matrix(),
                         kRoundTrip))
        << "sample " << i;
    ASSERT_TRUE(near_rel((T_a_b * T_b_c).matrix(), T_a_b.matrix() * T_b_c.matrix(), kRoundTrip));
    // T_a_b maps b to a: p_a = R p_b + t, and T_a_c = T_a_b * T_b_c.
    const Eigen::Vector3d p_b = T_b_c * p_c;
    ASSERT_TRUE(near_rel(p_b, T_b_c.rotation_matrix() * p_c + T_b_c.translation(), kRoundTrip));
    ASSERT_TRUE(near_rel((T_a_b * T_b_c) * p_c, T_a_b * p_b, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near_rel(T_a_b.inverse() * (T_a_b * p_b), p_b, kRoundTrip)) << "sample " << i;
  }
}

TEST_P(Se3ExpRanges, AdjointCarriesATwistThroughThePose) {
  // T exp(xi) T^-1 = exp(Ad_T xi) and T xi^ T^-1 = (Ad_T xi)^.
  GeometrySampler rng(test::seed_for("se3_adjoint", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SE3 T(SO3(rng.unit_quaternion()), rng.vector(10.0));
    const SE3 U = rng.pose(GetParam(), 10.0);
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const Matrix6d Ad = T.adjoint();
    ASSERT_TRUE(
        near_rel((T * SE3::exp(xi) * T.inverse()).matrix(), SE3::exp(Ad * xi).matrix(), kRoundTrip))
        << "sample " << i << " xi " << xi.transpose();
    ASSERT_TRUE(
        near_rel(T.matrix() * SE3::hat(xi) * T.inverse().matrix(), SE3::hat(Ad * xi), kRoundTrip));
    ASSERT_TRUE(near_rel((T * U).adjoint(), Ad * U.adjoint(), kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near_rel(T.inverse().adjoint() * Ad, Matrix6d::Identity(), kRoundTrip))
        << "sample " << i;
    // Ad(exp(xi)) = exp(ad(xi)) with ad = [[w^, v^], [0, w^]] for [v, w].
    ASSERT_TRUE(near_rel(SE3::exp(xi).adjoint(),
                         test::series_exp<6>(test::ad_ld(xi)).cast<double>(), kVsSeries))
        << "sample " << i << " xi " << xi.transpose();
  }
}

TEST_P(Se3LogRanges, LeftJacobianMatchesFiniteDifferences) {
  // exp(xi + d) ~= exp(J_l(xi) d) exp(xi).
  GeometrySampler rng(test::seed_for("se3_jl_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const SE3 T_inv = SE3::exp(xi).inverse();
    const Matrix6d numeric = central_difference<6, 6>(
        [&](const Vector6d& d) { return (SE3::exp(xi + d) * T_inv).log(); }, kFdStep);
    ASSERT_TRUE(near_rel(SE3::left_jacobian(xi), numeric, kFdTol))
        << "sample " << i << " xi " << xi.transpose();
  }
}

TEST_P(Se3LogRanges, RightJacobianIsTheLeftOneOfTheNegatedTwist) {
  // exp(xi + d) ~= exp(xi) exp(J_r(xi) d) with J_r(xi) = J_l(-xi) = Ad(exp(-xi)) J_l(xi).
  GeometrySampler rng(test::seed_for("se3_jr_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const SE3 T_inv = SE3::exp(xi).inverse();
    const Matrix6d numeric = central_difference<6, 6>(
        [&](const Vector6d& d) { return (T_inv * SE3::exp(xi + d)).log(); }, kFdStep);
    const Matrix6d Jr = SE3::left_jacobian(-xi);
    ASSERT_TRUE(near_rel(Jr, numeric, kFdTol)) << "sample " << i << " xi " << xi.transpose();
    ASSERT_TRUE(near_rel(SE3::left_jacobian(xi), SE3::exp(xi).adjoint() * Jr, kRoundTrip))
        << "sample " << i << " xi " << xi.transpose();
  }
}

TEST_P(Se3ExpRanges, LeftJacobianMatchesItsSeries) {
  // J_l = sum ad(xi)^n / (n+1)!, to a few ulps at every angle and across the series switch.
  GeometrySampler rng(test::seed_for("se3_jl_series", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    ASSERT_TRUE(near_rel(SE3::left_jacobian(xi), series_left_jacobian(xi), kVsSeries))
        << "sample " << i << " xi " << xi.transpose() << " |w| " << xi.tail<3>().norm();
  }
}

TEST_P(Se3LogRanges, LeftJacobianInverseMatchesTheSeriesAndInverts) {
  GeometrySampler rng(test::seed_for("se3_jl_inv", GetParam()));
  const Matrix6d I = Matrix6d::Identity();
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const Matrix6d J = SE3::left_jacobian(xi);
    const Matrix6d J_inv = SE3::left_jacobian_inverse(xi);
    ASSERT_TRUE(near_rel(J_inv, series_left_jacobian_inverse(xi), kVsSeries))
        << "sample " << i << " xi " << xi.transpose() << " |w| " << xi.tail<3>().norm();
    ASSERT_TRUE(near(J * J_inv, I, kRoundTrip)) << "sample " << i;
    ASSERT_TRUE(near(J_inv * J, I, kRoundTrip)) << "sample " << i;
  }
}

TEST_P(Se3SmoothLogRanges, LeftJacobianInverseIsTheDerivativeOfLog) {
  // d log(exp(d) T) / dd = J_l^-1(log T).
  GeometrySampler rng(test::seed_for("se3_jinv_fd", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const Vector6d xi = rng.twist(GetParam(), kMaxV);
    const SE3 T = SE3::exp(xi);
    const Matrix6d numeric = central_difference<6, 6>(
        [&](const Vector6d& d) { return (SE3::exp(d) * T).log(); }, kFdStep);
    ASSERT_TRUE(near_rel(SE3::left_jacobian_inverse(T.log()), numeric, kFdTol))
        << "sample " << i << " xi " << xi.transpose();
  }
}

TEST_P(Se3LogRanges, DerivativeOfTheActionOnAPoint) {
  // d(exp(d) T p)/dd = [I, -(T p)^]; d(T exp(d) p)/dd = R [I, -p^]: the 3-D part of the
  // warp Jacobian of the direct tracker, for left- and right-multiplied increments.
  GeometrySampler rng(test::seed_for("se3_action", GetParam()));
  for (int i = 0; i < GetParam().samples; ++i) {
    const SE3 T = rng.pose(GetParam(), 10.0);
    const Eigen::Vector3d p = rng.vector(10.0);
    const Matrix36d left = central_difference<3, 6>(
        [&](const Vector6d& d) -> Eigen::Vector3d { return SE3::exp(d) * (T * p); }, kFdStep);
    ASSERT_TRUE(near_rel(d_left_action_d_xi(T * p), left, kFdTol)) << "sample " << i;
    const Matrix36d right = central_difference<3, 6>(
        [&](const Vector6d& d) -> Eigen::Vector3d { return T * (SE3::exp(d) * p); }, kFdStep);
    ASSERT_TRUE(near_rel(Matrix36d(T.rotation_matrix() * d_left_action_d_xi(p)), right, kFdTol))
        << "sample " << i;
  }
}

TEST(Se3, FromMatrixRecoversThePose) {
  GeometrySampler rng(13);
  for (int i = 0; i < kSamples; ++i) {
    const SE3 T(SO3(rng.unit_quaternion()), rng.vector(10.0));
    const SE3 back = SE3::from_matrix(T.matrix());
    ASSERT_TRUE(near_rel(back.matrix(), T.matrix(), kRoundTrip)) << "sample " << i;
    const SE3 from_q(T.unit_quaternion(), T.translation());
    ASSERT_TRUE(near(from_q.matrix(), T.matrix(), 1e-14)) << "sample " << i;  // renormalised
  }
  EXPECT_TRUE(near(SE3().matrix(), Eigen::Matrix4d::Identity(), 0.0));
  EXPECT_TRUE(near(SE3().log(), Vector6d::Zero(), 0.0));
  EXPECT_TRUE(near(SE3::left_jacobian(Vector6d::Zero()), Matrix6d::Identity(), 0.0));
  EXPECT_TRUE(near(SE3::left_jacobian_inverse(Vector6d::Zero()), Matrix6d::Identity(), 0.0));
}

}  // namespace
}  // namespace kestrel
