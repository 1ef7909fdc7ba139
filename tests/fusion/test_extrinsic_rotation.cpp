// The online odometry-IMU rotation q_body_odom (docs/fusion.md, "Online odometry-IMU
// rotation"): its measurement Jacobian against finite differences, the prediction's known
// answer, a fixed rotation staying fixed, and a known misalignment recovered on a simulated
// flight.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "kestrel/core/units.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "kestrel/lab/fusion_simulation.hpp"
#include "numeric_jacobians.hpp"
#include "random_states.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;

TEST(ExtrinsicRotation, MeasurementJacobianMatchesFiniteDifferences) {
  std::mt19937_64 rng(31);
  double largest_column = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_states::random_state(rng, true, true);
    const Matrix6xs H = StochasticCloningEkf::measurement_jacobian(x);
    const Matrix6xs numeric_H = numeric::measurement_jacobian(x);
    for (int j = 0; j < idx::kDim; ++j) {
      EXPECT_LT((numeric_H.col(j) - H.col(j)).norm(), 1e-6) << "trial " << trial << " column " << j;
    }
    largest_column = std::max(largest_column, H.middleCols<3>(idx::kExt).norm());
  }
  EXPECT_GT(largest_column, 0.5);  // the columns are not trivially zero
}

TEST(ExtrinsicRotation, PredictionIsTheImuMotionSeenFromTheRotatedFrame) {
  // h = D^-1 T_clone_body D for the rigid transform D = (R_D, 0): the IMU's motion expressed in
  // the odometry's frame. At t_d = 0 with identity D it is the thesis' T_clone_body.
  std::mt19937_64 rng(37);
  for (int trial = 0; trial < 20; ++trial) {
    NominalState x = random_states::random_state(rng, false, true);
    const SE3 D(SO3(x.q_body_odom), Vector3d::Zero());
    const SE3 T_rel = x.T_world_clone().inverse() * x.T_world_body();
    const SE3 expected = D.inverse() * T_rel * D;
    const SE3 h = StochasticCloningEkf::predict_relative_pose(x);
    EXPECT_LT((h.translation() - expected.translation()).norm(), 1e-12) << trial;
    EXPECT_LT((h.so3().inverse() * expected.so3()).log().norm(), 1e-12) << trial;
    x.q_body_odom = Eigen::Quaterniond::Identity();
    const SE3 h0 = StochasticCloningEkf::predict_relative_pose(x);
    EXPECT_LT((h0.translation() - T_rel.translation()).norm(), 1e-12) << trial;
  }
}

TEST(ExtrinsicRotation, NotEstimatedItStaysFixed) {
  // Prior 0 (estimate_extrinsic_rotation off): the gain rows are zero, the rotation is
  // unchanged by an update that moves everything else.
  std::mt19937_64 rng(41);
  NominalState x = random_states::random_state(rng, false, true);
  x.p_clone_world = x.p_world;
  x.q_world_clone = x.q_world_body;
  StochasticCloningEkf ekf(ImuNoiseDensities{}, Vector3d(0, 0, -9.81));
  ekf.initialize(x, Matrix15d::Identity() * 1e-2);
  const Eigen::Quaterniond q0 = ekf.state().q_body_odom;
  ekf.propagate(random_states::random_reading(rng), 0.05);
  const SE3 z(SO3::exp(Vector3d(0.02, -0.01, 0.03)), Vector3d(0.05, 0.02, -0.03));
  ASSERT_TRUE(ekf.update(z, Matrix6d::Identity() * 1e-4, 0.0).accepted());
  EXPECT_EQ(ekf.state().q_body_odom.coeffs(), q0.coeffs());
  EXPECT_EQ(ekf.covariance().middleRows<3>(idx::kExt).norm(), 0.0);
}

// One simulated flight whose odometry frame is turned by `misalignment` (rotation vector, rad)
// against the IMU: the camera sits at R_D T_body_cam while the filter is told T_body_cam, so
// that the odometry's body motions are those of the frame rotated by R_D = exp(misalignment).
struct MisalignedRun {
  Vector3d estimate = Vector3d::Zero(), sigma = Vector3d::Zero();
  double rmse_m = 0.0;
};

MisalignedRun misaligned_flight(const Vector3d& misalignment, bool estimate, std::uint64_t seed) {
  lab::SimulationOptions sim;
  sim.duration_s = 30.0;
  sim.vo_keyframes = true;
  FusionOptions fusion;
  fusion.estimate_extrinsic_rotation = estimate;
  fusion.T_body_cam = sim.T_body_cam;  // what the filter is told
  fusion.reorder_window_s = 0.0;
  sim.T_body_cam = SE3(SO3::exp(misalignment), Vector3d::Zero()) * sim.T_body_cam;  // the truth
  std::mt19937_64 rng(seed * 1000003ULL);
  const lab::SimulatedFlight flight(seed + 1);
  const lab::SimulatedRun run = lab::simulate_run(flight, sim, fusion, rng);
  FusionEngine engine(fusion);
  NominalState x0 = lab::true_state(flight, run, 0, sim.imu_rate_hz);
  x0.gyro_bias_rad_s.setZero();
  x0.accel_bias_m_s2.setZero();
  engine.initialize(x0);
  double se = 0.0;
  std::size_t n = 0, i = 0;
  for (const auto& m : run.odometry) {
    while (i < run.imu.size() && run.imu[i].t_ns <= m.t_ns) engine.add_imu(run.imu[i++]);
    engine.add_relative_pose(m);
    (void)engine.flush(false);
    if (m.t_ns <= 0) continue;
    const Vector3d p = flight.at(ns_to_s(m.t_ns)).T_world_body.translation();
    se += (engine.filter().state().p_world - p).squaredNorm();
    ++n;
  }
  MisalignedRun r;
  r.estimate = SO3(engine.filter().state().q_body_odom).log();
  r.sigma = engine.filter().covariance().diagonal().segment<3>(idx::kExt).cwiseMax(0.0).cwiseSqrt();
  r.rmse_m = n ? std::sqrt(se / static_cast<double>(n)) : 0.0;
  return r;
}

// A 1 deg misalignment (about a tilted axis) on 3 simulated 30 s flights with the issue's
// keyframe odometry (1 cm / 0.5 deg), prior 2 deg: recovered within 3 sigma per axis and within
// 0.6 deg (3 x the ~0.2 deg 1-sigma it ends with), and with no misalignment the estimate stays
// within 3 sigma of zero. Measured over flights 1-10 (docs/fusion.md): largest error 2.7 sigma,
// mean NEES of the 3 axes 4.0 (3 for a consistent estimate); at 1 deg estimating it leaves the
// fused position error as it is (0.155 against 0.151 m ignored).
TEST(ExtrinsicRotation, KnownMisalignmentIsRecoveredOnSimulatedFlights) {
  const Vector3d truth = Vector3d(0.6, -0.5, 0.6).normalized() * (1.0 / kRadToDeg);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const MisalignedRun on = misaligned_flight(truth, true, seed);
    const MisalignedRun zero = misaligned_flight(Vector3d::Zero(), true, seed);
    std::cout << "flight " << seed << ": estimate " << (on.estimate * kRadToDeg).transpose()
              << " deg (truth " << (truth * kRadToDeg).transpose() << ", 1-sigma "
              << (on.sigma * kRadToDeg).transpose()
              << "); no misalignment: " << (zero.estimate * kRadToDeg).transpose() << " deg\n";
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(on.estimate(k), truth(k), 3.0 * on.sigma(k))
          << "flight " << seed << " axis " << k;
      EXPECT_NEAR(zero.estimate(k), 0.0, 3.0 * zero.sigma(k)) << "flight " << seed << " axis " << k;
    }
    EXPECT_LT((on.estimate - truth).norm(), 0.6 / kRadToDeg) << "flight " << seed;
    EXPECT_LT(on.sigma.maxCoeff(), 0.3 / kRadToDeg) << "flight " << seed;  // from the 2 deg prior
  }
}

// Where the misalignment is large enough to matter against 1 cm / 0.5 deg odometry (3 deg),
// estimating it beats taking T_body_cam as exact (measured over flights 1-10: fused position
// RMSE 0.154 against 0.182 m; at 1 deg 0.155 against 0.151 m, no gain).
TEST(ExtrinsicRotation, EstimatingItBeatsIgnoringAThreeDegreeMisalignment) {
  const Vector3d truth = Vector3d(0.6, -0.5, 0.6).normalized() * (3.0 / kRadToDeg);
  double sum_on = 0.0, sum_off = 0.0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const MisalignedRun on = misaligned_flight(truth, true, seed);
    const MisalignedRun off = misaligned_flight(truth, false, seed);
    std::cout << "flight " << seed << ": RMSE " << on.rmse_m << " m estimated, " << off.rmse_m
              << " m ignored\n";
    sum_on += on.rmse_m;
    sum_off += off.rmse_m;
  }
  EXPECT_LT(sum_on, sum_off);
}

}  // namespace
}  // namespace kestrel::fusion
