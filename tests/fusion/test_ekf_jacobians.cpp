// The fusion's Jacobians against central finite differences, over many random states.
#include <gtest/gtest.h>

#include <random>

#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "numeric_jacobians.hpp"
#include "random_states.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;

using random_states::random_reading;
using random_states::random_state;

TEST(FusionJacobians, PropagationTransitionMatchesFiniteDifferences) {
  std::mt19937_64 rng(7);
  const Vector3d g(0, 0, -9.81);
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_state(rng);
    const ImuReading m = random_reading(rng);
    const double dt = trial % 2 ? 0.005 : 0.05;
    const Matrix15d F = StochasticCloningEkf::transition(x, m, dt);
    const NominalState y0 = StochasticCloningEkf::propagate_nominal(x, m, dt, g);
    const double h = 1e-6;
    for (int j = 0; j < idx::kCore; ++j) {
      VectorXs d = VectorXs::Zero();
      d(j) = h;
      const NominalState yp = StochasticCloningEkf::propagate_nominal(x.boxplus(d), m, dt, g);
      const NominalState ym = StochasticCloningEkf::propagate_nominal(x.boxplus(-d), m, dt, g);
      const VectorXs col = (yp.boxminus(y0) - ym.boxminus(y0)) / (2 * h);
      EXPECT_LT((col.head<15>() - F.col(j)).norm(), 1e-6) << "trial " << trial << " column " << j;
    }
  }
}

TEST(FusionJacobians, TransitionIsFirstOrderContinuousModel) {
  // dF = I + cF dt to first order (thesis, after eq. 4.4).
  std::mt19937_64 rng(3);
  const NominalState x = random_state(rng);
  const ImuReading m = random_reading(rng);
  const double dt = 1e-5;
  const Matrix15d F = StochasticCloningEkf::transition(x, m, dt);
  const Eigen::Matrix3d R = x.q_world_body.toRotationMatrix();
  const Vector3d w = m.gyro_rad_s - x.gyro_bias_rad_s, a = m.accel_m_s2 - x.accel_bias_m_s2;
  Matrix15d cF = Matrix15d::Zero();
  cF.block<3, 3>(idx::kP, idx::kV).setIdentity();
  cF.block<3, 3>(idx::kTheta, idx::kTheta) = -SO3::hat(w);
  cF.block<3, 3>(idx::kTheta, idx::kBg) = -Eigen::Matrix3d::Identity();
  cF.block<3, 3>(idx::kV, idx::kTheta) = -R * SO3::hat(a);
  cF.block<3, 3>(idx::kV, idx::kBa) = -R;
  EXPECT_LT((F - (Matrix15d::Identity() + cF * dt)).norm(), 1e-8);
}

TEST(FusionJacobians, MeasurementJacobianMatchesFiniteDifferences) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_state(rng);
    const Matrix6xs H = StochasticCloningEkf::measurement_jacobian(x);
    const Matrix6xs numeric_H = numeric::measurement_jacobian(x);
    for (int j = 0; j < idx::kDim; ++j) {
      EXPECT_LT((numeric_H.col(j) - H.col(j)).norm(), 1e-6) << "trial " << trial << " column " << j;
    }
  }
}

// The directions no relative-pose measurement can see, at state x (core rows, clone rows from
// the clone pose given): a global translation (3 columns) and a yaw about gravity z (1 column).
Eigen::Matrix<double, idx::kDim, 4> unobservable(const NominalState& x, const SE3& clone) {
  Eigen::Matrix<double, idx::kDim, 4> N = Eigen::Matrix<double, idx::kDim, 4>::Zero();
  const Vector3d z = Vector3d::UnitZ();
  N.block<3, 3>(idx::kP, 0).setIdentity();
  N.block<3, 3>(idx::kPd, 0).setIdentity();
  N.block<3, 1>(idx::kP, 3) = z.cross(x.p_world);
  N.block<3, 1>(idx::kTheta, 3) = x.q_world_body.toRotationMatrix().transpose() * z;
  N.block<3, 1>(idx::kV, 3) = z.cross(x.v_world);
  N.block<3, 1>(idx::kPd, 3) = z.cross(clone.translation());
  N.block<3, 1>(idx::kThetaD, 3) = clone.rotation_matrix().transpose() * z;
  return N;
}

TEST(FusionJacobians, MeasurementJacobianAnnihilatesTheUnobservableDirections) {
  std::mt19937_64 rng(13);
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_state(rng);
    const auto N = unobservable(x, x.T_world_clone());
    EXPECT_LT((StochasticCloningEkf::measurement_jacobian(x) * N).norm(), 1e-12) << trial;
  }
}

// First-estimates transition (Li & Mourikis 2013): at fe = x it is transition(); at a first
// estimate fe != x it maps the unobservable directions at fe onto those after the step, which
// the transition at x does not (it maps those at x).
TEST(FusionJacobians, FirstEstimatesTransitionMapsTheUnobservableDirections) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n(0.0, 1.0);
  const Vector3d g(0, 0, -9.81);
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_state(rng);
    const ImuReading m = random_reading(rng);
    const double dt = trial % 2 ? 0.005 : 0.05;
    const NominalState next = StochasticCloningEkf::propagate_nominal(x, m, dt, g);
    const Matrix15d F = StochasticCloningEkf::transition(x, m, dt);
    EXPECT_LT((StochasticCloningEkf::transition_first_estimates(x, x, next, m, dt, g) - F).norm(),
              1e-9);
    VectorXs d = VectorXs::Zero();  // an update's correction: fe = x before it
    for (int i = 0; i < idx::kCore; ++i) d(i) = 0.05 * n(rng);
    const NominalState fe = x.boxplus(d);
    const Matrix15d Ffe = StochasticCloningEkf::transition_first_estimates(x, fe, next, m, dt, g);
    const Eigen::Matrix<double, idx::kCore, 4> N_fe =
        unobservable(fe, fe.T_world_clone()).topRows<idx::kCore>();
    const Eigen::Matrix<double, idx::kCore, 4> N_next =
        unobservable(next, next.T_world_clone()).topRows<idx::kCore>();
    EXPECT_LT((Ffe * N_fe - N_next).norm(), 1e-9) << trial;
    EXPECT_GT((F * N_fe - N_next).norm(), 1e-4) << trial;  // the plain one does not
  }
}

TEST(FusionJacobians, LeftPerturbationCovarianceMapping) {
  // residual(exp(xi) T, T) ~ J xi: check J column by column with finite differences.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Vector6d t;
    for (int i = 0; i < 6; ++i) t(i) = n(rng);
    const SE3 T = SE3::exp(t);
    Matrix6d J;
    const double h = 1e-6;
    for (int j = 0; j < 6; ++j) {
      Vector6d d = Vector6d::Zero();
      d(j) = h;
      J.col(j) = (StochasticCloningEkf::residual(SE3::exp(d) * T, T) -
                  StochasticCloningEkf::residual(SE3::exp(-d) * T, T)) /
                 (2 * h);
    }
    Matrix6d C = Matrix6d::Identity();
    C(0, 3) = C(3, 0) = 0.3;
    C(2, 2) = 4.0;
    const Matrix6d expected = J * C * J.transpose();
    EXPECT_LT((StochasticCloningEkf::left_to_residual_covariance(T, C) - expected).norm(), 1e-6);
  }
}

TEST(FusionJacobians, ChiSquareQuantiles) {
  EXPECT_NEAR(chi_square_quantile(0.95, 3), 7.814727903, 1e-6);
  EXPECT_NEAR(chi_square_quantile(0.999, 6), 22.45774448, 1e-6);
  EXPECT_NEAR(chi_square_quantile(0.025, 150), 117.9845, 1e-3);
  EXPECT_NEAR(chi_square_quantile(0.975, 150), 185.8004, 1e-3);
  EXPECT_THROW(chi_square_quantile(1.0, 3), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::fusion
