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

// The initial clone is taken before any IMU reading: its rate comes from the first reading
// (bias removed), not from the initial state's zero, and a later clone keeps its own rate.
// With a zero rate the t_d column of every measurement against the first keyframe read the full
// rate, and the filter's t_d 1-sigma fell to 0.40x of what the measurements allow.
TEST(TimeOffset, TheInitialClonesRateIsTheFirstReadings) {
  NominalState x;
  x.gyro_bias_rad_s = Vector3d(0.01, 0.0, -0.02);
  StochasticCloningEkf ekf;
  ekf.initialize(x, Matrix15d::Identity() * 1e-4, 0.02);
  EXPECT_EQ(ekf.state().omega_clone_body, Vector3d::Zero());
  const Vector3d gyro(0.3, -0.2, 0.5);
  ekf.propagate({gyro, Vector3d(0, 0, 9.81)}, 0.005);
  EXPECT_TRUE(ekf.state().omega_clone_body.isApprox(gyro - x.gyro_bias_rad_s));
  ekf.propagate({Vector3d(-0.4, 0.1, 0.0), Vector3d(0, 0, 9.81)}, 0.005);
  EXPECT_TRUE(ekf.state().omega_clone_body.isApprox(gyro - x.gyro_bias_rad_s));  // unchanged
  Matrix6d R = Matrix6d::Identity() * 1e-4;
  (void)ekf.update(StochasticCloningEkf::predict_relative_pose(ekf.state()), R, 0.0);
  ekf.clone();  // a new keyframe: at the current rate
  EXPECT_TRUE(ekf.state().omega_clone_body.isApprox(ekf.state().omega_body));
  ekf.propagate({Vector3d(0.7, 0.7, 0.7), Vector3d(0, 0, 9.81)}, 0.005);
  EXPECT_TRUE(ekf.state().omega_clone_body.isApprox(Vector3d(-0.4, 0.1, 0.0) - x.gyro_bias_rad_s));
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

// Offsets of -20, 0 and +15 ms (the issue's) on flights 1-5, keyframe odometry with 1 cm /
// 0.5 deg: at 30 s every estimate is within 3 sigma of the truth, the 1-sigma below 1.5 ms, and
// the filter's 1-sigma within 10 % of the oracle bound (measured 1-5 %): it takes nearly all
// the information the measurements carry. How soon it is within 1 ms is not asserted: the
// oracle bound itself is 1.5-2.4 ms at 10 s on these flights (the 10 s is MISSED for
// lack of information, docs/fusion.md).
TEST(TimeOffset, RecoveredOnSimulatedFlights) {
  lab::SimulationOptions sim;
  sim.duration_s = 30.0;
  sim.vo_keyframes = true;  // as the odometry reports them by default
  const FusionOptions options;
  double sum_sq_normalised = 0.0;
  int runs = 0;
  for (const std::uint64_t flight : {1U, 2U, 3U, 4U, 5U}) {
    for (const double ms : {-20.0, 0.0, 15.0}) {
      const lab::TimeOffsetRun r = lab::time_offset_run(sim, options, 1e-3 * ms, flight);
      const double error = r.final_estimate_s - 1e-3 * ms;
      const double oracle = r.oracle_sigma_s.back();
      std::cout << "flight " << flight << ", " << ms << " ms: t_d " << 1e3 * r.final_estimate_s
                << " +- " << 1e3 * r.final_sigma_s << " ms (oracle " << 1e3 * oracle << ")\n";
      EXPECT_LT(std::abs(error), 3.0 * r.final_sigma_s) << flight << ", " << ms << " ms";
      EXPECT_LT(r.final_sigma_s, 1.5e-3) << flight << ", " << ms << " ms";  // from 20 ms
      EXPECT_LT(r.final_sigma_s, 1.1 * oracle) << flight << ", " << ms << " ms";
      sum_sq_normalised += error * error / (r.final_sigma_s * r.final_sigma_s);
      ++runs;
    }
  }
  // Consistent: the three offsets of a flight share its noise, so about 5 independent draws;
  // 2.57 is chi2(5)'s 97.5 % quantile / 5 (measured 1.03).
  const double mean_sq = sum_sq_normalised / runs;
  std::cout << "mean (error / sigma)^2 at 30 s: " << mean_sq << "\n";
  EXPECT_LT(mean_sq, 2.57);
}

// The oracle bound (every quantity but t_d known) is the best any estimator can do with these
// measurements: it starts at the prior, only shrinks, and the filter, which must also estimate
// the pose, velocity and biases, is not surer than it (a filter far below it would be
// over-confident about t_d). The EKF's Jacobians are taken at its estimates, not at the truth,
// so its 1-sigma could dip a little under the bound; the lowest ratio on these runs is 1.0005
// (0.40 while the initial clone took a zero rate, before the first IMU reading gave it).
TEST(TimeOffset, TheFilterIsNoSurerThanTheOracleBound) {
  lab::SimulationOptions sim;
  sim.duration_s = 15.0;
  sim.vo_keyframes = true;
  const FusionOptions options;
  double lowest_ratio = 1e9;
  for (const std::uint64_t flight : {1U, 2U, 3U}) {
    for (const double ms : {-20.0, 0.0, 15.0}) {
      const lab::TimeOffsetRun r = lab::time_offset_run(sim, options, 1e-3 * ms, flight);
      ASSERT_EQ(r.sigma_s.size(), r.t_s.size());
      ASSERT_EQ(r.oracle_sigma_s.size(), r.t_s.size());
      ASSERT_GT(r.t_s.size(), 100U);
      EXPECT_LT(r.oracle_sigma_s.front(), options.init_sigma_time_offset_s);
      for (std::size_t k = 0; k < r.t_s.size(); ++k) {
        if (k > 0) {
          EXPECT_LE(r.oracle_sigma_s[k], r.oracle_sigma_s[k - 1]) << "at " << r.t_s[k];
        }
        lowest_ratio = std::min(lowest_ratio, r.sigma_s[k] / r.oracle_sigma_s[k]);
        EXPECT_GE(r.sigma_s[k], 0.98 * r.oracle_sigma_s[k])
            << "flight " << flight << ", " << ms << " ms, at " << r.t_s[k] << " s";
      }
      // Not vacuous: the measurements carry t_d to a few ms within seconds.
      EXPECT_LT(lab::value_at(r.t_s, r.oracle_sigma_s, 10.0), 5e-3);
    }
  }
  std::cout << "lowest filter / oracle 1-sigma: " << lowest_ratio << "\n";
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
