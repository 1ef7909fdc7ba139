// The camera-IMU time offset t_d: its measurement Jacobian against finite differences, the
// unobservable directions with an offset, its recovery on simulated flights, and the in-flight
// IMU noise factor of the sensor file.
#include <gtest/gtest.h>

#include <fstream>
#include <iostream>
#include <random>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/lab/fusion_simulation.hpp"
#include "numeric_jacobians.hpp"
#include "random_states.hpp"
#include "test_data.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;

TEST(TimeOffset, MeasurementJacobianMatchesFiniteDifferencesWithAnOffset) {
  std::mt19937_64 rng(23);
  double largest_td_column = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_states::random_state(rng, true);
    const Matrix6xs H = StochasticCloningEkf::measurement_jacobian(x);
    const Matrix6xs numeric_H = numeric::measurement_jacobian(x);
    for (int j = 0; j < idx::kDim; ++j) {
      EXPECT_LT((numeric_H.col(j) - H.col(j)).norm(), 1e-6) << "trial " << trial << " column " << j;
    }
    largest_td_column = std::max(largest_td_column, H.col(idx::kTd).norm());
  }
  EXPECT_GT(largest_td_column, 1.0);  // the column is not trivially zero
}

TEST(TimeOffset, ShiftedPredictionIsTheFramesMovedAlongTheirMotion) {
  // With the clone at rest and the body moving at v, turning at w, the predicted relative
  // pose is the body's pose t_d later: translation R_d^T v t_d, rotation exp(w t_d).
  NominalState x;
  x.v_world = Vector3d(1.0, -0.5, 0.2);
  x.omega_body = Vector3d(0.3, 0.0, -1.0);
  x.time_offset_s = 0.015;
  const SE3 T = StochasticCloningEkf::predict_relative_pose(x);
  EXPECT_LT((T.translation() - x.v_world * 0.015).norm(), 1e-12);
  EXPECT_LT((T.so3().log() - x.omega_body * 0.015).norm(), 1e-12);
}

TEST(TimeOffset, AYawOfTheWholeStateStaysUnseenWithAnOffset) {
  // The clone's velocity is held in its body frame, so a global yaw (and translation) leaves
  // the shifted measurement unchanged: H N = 0 with t_d != 0, as at t_d = 0.
  std::mt19937_64 rng(29);
  for (int trial = 0; trial < 50; ++trial) {
    const NominalState x = random_states::random_state(rng, true);
    Eigen::Matrix<double, idx::kDim, 4> N = Eigen::Matrix<double, idx::kDim, 4>::Zero();
    const Vector3d z = Vector3d::UnitZ();
    N.block<3, 3>(idx::kP, 0).setIdentity();
    N.block<3, 3>(idx::kPd, 0).setIdentity();
    N.block<3, 1>(idx::kP, 3) = z.cross(x.p_world);
    N.block<3, 1>(idx::kTheta, 3) = x.q_world_body.toRotationMatrix().transpose() * z;
    N.block<3, 1>(idx::kV, 3) = z.cross(x.v_world);
    N.block<3, 1>(idx::kPd, 3) = z.cross(x.p_clone_world);
    N.block<3, 1>(idx::kThetaD, 3) = x.q_world_clone.toRotationMatrix().transpose() * z;
    EXPECT_LT((StochasticCloningEkf::measurement_jacobian(x) * N).norm(), 1e-12) << trial;
  }
}

TEST(TimeOffset, NotEstimatedItStaysFixed) {
  NominalState x;
  Matrix15d P = Matrix15d::Identity() * 1e-4;
  StochasticCloningEkf ekf;
  ekf.initialize(x, P, 0.0);
  ekf.propagate({Vector3d(0.5, 0, 0), Vector3d(0, 0, 9.81)}, 0.05);
  Matrix6d R = Matrix6d::Identity() * 1e-4;
  (void)ekf.update(SE3(SO3::exp(Vector3d(0.04, 0, 0)), Vector3d(0.01, 0, 0)), R, 0.0);
  EXPECT_EQ(ekf.state().time_offset_s, 0.0);
  EXPECT_EQ(ekf.covariance()(idx::kTd, idx::kTd), 0.0);
}

// Bad input with the offset state: a gap of seconds leaves t_d and its variance as they were
// (a constant; nothing to grow), and a non-finite measurement is refused, never propagated
// into t_d.
TEST(TimeOffset, GapAndNonFiniteMeasurementLeaveItFinite) {
  NominalState x;
  x.time_offset_s = 0.004;
  StochasticCloningEkf ekf;
  ekf.initialize(x, Matrix15d::Identity() * 1e-4, 0.02);
  for (int k = 0; k < 600; ++k) ekf.propagate({Vector3d(0.1, 0, 0), Vector3d(0, 0, 9.81)}, 0.005);
  EXPECT_EQ(ekf.state().time_offset_s, 0.004);
  EXPECT_DOUBLE_EQ(ekf.covariance()(idx::kTd, idx::kTd), 0.02 * 0.02);
  EXPECT_GT(ekf.covariance()(idx::kP, idx::kP), 1e-4);  // the position did grow over the gap
  const NominalState before = ekf.state();
  SE3 bad(SO3(), Vector3d(std::nan(""), 0, 0));
  const UpdateResult r = ekf.update(bad, Matrix6d::Identity() * 1e-4, 0.0);
  EXPECT_EQ(r.outcome, UpdateOutcome::kRejectedInvalid);
  EXPECT_EQ(ekf.state().time_offset_s, before.time_offset_s);
  EXPECT_TRUE(ekf.state().all_finite());
  EXPECT_TRUE(ekf.covariance().allFinite());
  EXPECT_THROW(ekf.initialize(x, Matrix15d::Identity(), std::nan("")), std::invalid_argument);
}

// Offsets of -20, 0 and +15 ms on a simulated flight (the issue's), keyframe odometry with
// 1 cm / 0.5 deg: t_d stays within 1 ms of the truth from 13.5-16.0 s on (measured on this
// flight; the 10 s is MISSED: the relative poses carry t_d only through the change of
// velocity and rate between the two frames, and the filter's own 1-sigma is still 0.9 ms at
// 30 s, docs/fusion.md). REGRESSION GUARD at 20 s, and the estimate within 3 sigma.
TEST(TimeOffset, RecoveredOnASimulatedFlight) {
  lab::SimulationOptions sim;
  sim.duration_s = 30.0;
  sim.vo_keyframes = true;  // as the odometry reports them by default
  const FusionOptions options;
  for (const double ms : {-20.0, 0.0, 15.0}) {
    const lab::TimeOffsetRun r = lab::time_offset_run(sim, options, 1e-3 * ms, 1);
    std::cout << ms << " ms: t_d " << 1e3 * r.final_estimate_s << " +- " << 1e3 * r.final_sigma_s
              << " ms, within 1 ms after " << r.converged_after_s << " s\n";
    EXPECT_GE(r.converged_after_s, 0.0) << ms << " ms: not within 1 ms at the end";
    EXPECT_LE(r.converged_after_s, 20.0) << ms << " ms";
    EXPECT_NEAR(r.final_estimate_s, 1e-3 * ms, 3.0 * r.final_sigma_s) << ms << " ms";
    EXPECT_LT(r.final_sigma_s, 1.5e-3) << ms << " ms";  // from the 20 ms prior
  }
}

// Where the odometry is precise enough for 15 ms to matter (2 mm / 0.1 deg per keyframe
// measurement), estimating the offset beats ignoring it. With the 1 cm / 0.5 deg of the
// issue's runs it hardly does (docs/fusion.md): the offset shifts a 50 ms motion by its change
// of velocity and rate over 15 ms, below that noise.
TEST(TimeOffset, EstimatingItBeatsIgnoringItWithPreciseOdometry) {
  lab::SimulationOptions sim;
  sim.duration_s = 30.0;
  sim.vo_keyframes = true;
  sim.vo_sigma_p_m = 0.002;
  sim.vo_sigma_rot_deg = 0.1;
  FusionOptions on;
  FusionOptions off;
  off.estimate_time_offset = false;
  double sum_on = 0.0, sum_off = 0.0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const auto r_on = lab::time_offset_run(sim, on, 0.015, seed);
    const auto r_off = lab::time_offset_run(sim, off, 0.015, seed);
    std::cout << "flight " << seed << ": estimated " << r_on.fused_rmse_after_m << " m (t_d "
              << 1e3 * r_on.final_estimate_s << " ms), ignored " << r_off.fused_rmse_after_m
              << " m\n";
    EXPECT_EQ(r_off.final_estimate_s, 0.0);
    EXPECT_NEAR(r_on.final_estimate_s, 0.015, 1e-3);
    sum_on += r_on.fused_rmse_after_m;
    sum_off += r_off.fused_rmse_after_m;
  }
  EXPECT_LT(sum_on, sum_off);
}

TEST(ImuNoiseInflation, SensorFileGivesItOrTheInFlightDefault) {
  const auto dir = test::fresh_temp_dir("fusion_inflation");
  const std::string base =
      "%YAML:1.0\nrate_hz: 200\ngyroscope_noise_density: 1.6e-4\ngyroscope_random_walk: 1.9e-5\n"
      "accelerometer_noise_density: 2e-3\naccelerometer_random_walk: 3e-3\n";
  std::ofstream(dir / "plain.yaml") << base;
  std::ofstream(dir / "given.yaml") << base << "in_flight_noise_inflation: 4\n";
  std::ofstream(dir / "bad.yaml") << base << "in_flight_noise_inflation: -2\n";
  FusionOptions o;
  EXPECT_EQ(o.imu_noise_inflation, 0.0);  // options alone: unset, the densities as given
  EXPECT_DOUBLE_EQ(o.filter_noise().gyro_noise, o.noise.gyro_noise);
  FusionOptions explicit_one;  // a value the options set is kept over the sensor file's
  explicit_one.imu_noise_inflation = 1.0;
  explicit_one.set_imu_noise(io::load_imu_noise(dir / "given.yaml"));
  EXPECT_EQ(explicit_one.imu_noise_inflation, 1.0);
  o.set_imu_noise(io::load_imu_noise(dir / "plain.yaml"));
  EXPECT_EQ(o.imu_noise_inflation, kInFlightImuNoiseInflation);
  EXPECT_DOUBLE_EQ(o.filter_noise().gyro_noise, 1.6e-4 * kInFlightImuNoiseInflation);
  EXPECT_DOUBLE_EQ(o.filter_noise().gyro_walk, 1.9e-5);  // the walks are not inflated
  FusionOptions from_file;
  from_file.set_imu_noise(io::load_imu_noise(dir / "given.yaml"));
  EXPECT_EQ(from_file.imu_noise_inflation, 4.0);
  try {
    (void)io::load_imu_noise(dir / "bad.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("in_flight_noise_inflation"), std::string::npos)
        << e.what();
  }
  FusionOptions nan_offset;
  nan_offset.time_offset_s = std::nan("");
  EXPECT_THROW(nan_offset.validate(), InputError);
  FusionOptions negative_inflation;
  negative_inflation.imu_noise_inflation = -1.0;
  EXPECT_THROW(negative_inflation.validate(), InputError);
}

}  // namespace
}  // namespace kestrel::fusion
