// The EKF's covariance steps against their dense textbook forms: the structured propagation
// P <- F P F^T + dQ (thesis eq. 4.6) and the expanded Joseph update (thesis eq. 4.8).
#include <gtest/gtest.h>

#include <random>

#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "random_states.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;
using random_states::random_reading;
using random_states::random_state;

MatrixXs random_spd_covariance(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  MatrixXs A;
  for (int i = 0; i < A.size(); ++i) A.data()[i] = n(rng);
  const MatrixXs P = A * A.transpose() + 0.1 * MatrixXs::Identity();
  return 0.5 * (P + P.transpose());  // exactly symmetric, as the filter keeps its covariance
}

double relative_difference(const MatrixXs& a, const MatrixXs& b) {
  return (a - b).norm() / b.norm();
}

// The structure propagate_covariance() relies on, for both transitions the filter uses.
void expect_transition_structure(const Matrix15d& F) {
  Matrix15d pattern = Matrix15d::Identity();
  for (const int row : {idx::kP, idx::kTheta, idx::kV}) {
    for (const int col : {idx::kTheta, idx::kBg, idx::kBa}) {
      pattern.block<3, 3>(row, col).setConstant(1.0);
    }
  }
  pattern.block<3, 3>(idx::kTheta, idx::kBa).setZero();
  for (int r = 0; r < idx::kCore; ++r) {
    for (int c = 0; c < idx::kCore; ++c) {
      if (r >= idx::kP && r < idx::kP + 3 && c == r + idx::kV) {
        EXPECT_EQ(F(r, c), F(idx::kP, idx::kV)) << "p-over-v diagonal " << r;
      } else if (pattern(r, c) == 0.0) {
        EXPECT_EQ(F(r, c), 0.0) << "structural zero at " << r << ", " << c;
      } else if (r == c && (r < idx::kTheta || r >= idx::kV)) {
        EXPECT_EQ(F(r, c), 1.0) << "identity at " << r;
      }
    }
  }
}

MatrixXs dense_propagation(const MatrixXs& P, const Matrix15d& F, const Vector15d& q) {
  MatrixXs Phi = MatrixXs::Identity();
  Phi.topLeftCorner<idx::kCore, idx::kCore>() = F;
  MatrixXs Pn = Phi * P * Phi.transpose();
  Pn.topLeftCorner<idx::kCore, idx::kCore>().diagonal() += q;
  return Pn;
}

TEST(FusionCovarianceSteps, StructuredPropagationEqualsTheDenseProduct) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  const Vector3d g(0, 0, -9.81);
  const ImuNoiseDensities noise;
  for (int trial = 0; trial < 40; ++trial) {
    const NominalState x = random_state(rng);
    const ImuReading m = random_reading(rng);
    const double dt = trial % 2 ? 0.001 : 0.05;
    const NominalState next = StochasticCloningEkf::propagate_nominal(x, m, dt, g);
    VectorXs d = VectorXs::Zero();
    for (int i = 0; i < idx::kCore; ++i) d(i) = 0.05 * n(rng);
    const Matrix15d F = trial % 4 < 2 ? StochasticCloningEkf::transition(x, m, dt)
                                      : StochasticCloningEkf::transition_first_estimates(
                                            x, x.boxplus(d), next, m, dt, g);
    expect_transition_structure(F);
    const MatrixXs P = random_spd_covariance(rng);
    const Vector15d q = StochasticCloningEkf::process_noise(noise, dt).diagonal();
    MatrixXs got = P;
    StochasticCloningEkf::propagate_covariance(got, F, q);
    EXPECT_LT(relative_difference(got, dense_propagation(P, F, q)), 1e-14) << "trial " << trial;
    EXPECT_EQ((got - got.transpose()).norm(), 0.0) << "not symmetric, trial " << trial;
  }
}

TEST(FusionCovarianceSteps, ExpandedJosephEqualsTheProductFormForAnyGain) {
  std::mt19937_64 rng(13);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const MatrixXs P = random_spd_covariance(rng);
    const NominalState x = random_state(rng, /*offset_and_rates=*/true);
    const Matrix6xs H = StochasticCloningEkf::measurement_jacobian(x);
    Matrix6d B;
    for (int i = 0; i < B.size(); ++i) B.data()[i] = n(rng);
    const Matrix6d R = 0.01 * (B * B.transpose()) + 1e-3 * Matrix6d::Identity();
    const Eigen::Matrix<double, idx::kDim, 6> PHt = P * H.transpose();
    const Eigen::Matrix<double, idx::kDim, 6> PHt_kernel =
        StochasticCloningEkf::covariance_times_transpose(P, H);
    EXPECT_LT((PHt_kernel - PHt).norm(), 1e-14 * PHt.norm()) << "P H^T, trial " << trial;
    const Matrix6d S = H * PHt + R;
    Eigen::Matrix<double, idx::kDim, 6> K = PHt * S.inverse();
    // The optimal gain and one off by a few percent (Joseph's form holds for any K).
    if (trial % 2) {
      for (int i = 0; i < K.size(); ++i) K.data()[i] *= 1.0 + 0.05 * n(rng);
    }
    MatrixXs IKH = MatrixXs::Identity() - K * H;
    const MatrixXs product = IKH * P * IKH.transpose() + K * R * K.transpose();
    MatrixXs got = P;
    StochasticCloningEkf::joseph_update(got, K, PHt, S);
    EXPECT_LT(relative_difference(got, product), 1e-12) << "trial " << trial;
    EXPECT_EQ((got - got.transpose()).norm(), 0.0) << "not symmetric, trial " << trial;
    const Eigen::SelfAdjointEigenSolver<MatrixXs> eig(got);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0) << "not positive definite, trial " << trial;
  }
}

}  // namespace
}  // namespace kestrel::fusion
