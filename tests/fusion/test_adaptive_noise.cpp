// The odometry covariance's online scale (fusion/adaptive_noise.hpp): it converges to the true
// noise's ratio to the reported one, stays at 1 for a consistent stream, is bounded, and refuses
// bad input. First the estimator on innovations drawn from a known linear model, then the whole
// filter on simulated flights whose odometry is k times noisier than it reports.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/adaptive_noise.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/lab/fusion_simulation.hpp"

namespace kestrel::fusion {
namespace {

constexpr int kDof = 6;
const double kGate = chi_square_quantile(0.999, kDof);

AdaptiveNoiseOptions wide_options() {
  AdaptiveNoiseOptions o;
  o.enabled = true;
  o.max_scale = 100.0;  // wide enough to show where the estimate goes
  return o;
}

// Innovations r ~ N(0, (p + k) I) per axis, the filter's S = (p + lambda) I: the reported R is
// I, the prediction's H P H^T is p I. Returns the mean scale over the second half of n updates.
double run_linear_model(NisNoiseScale& est, double k, double p, int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  double sum = 0.0;
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const double lambda = est.scale();
    double r2 = 0.0;
    for (int d = 0; d < kDof; ++d) {
      const double r = std::sqrt(p + k) * normal(rng);
      r2 += r * r;
    }
    est.add(r2 / (p + lambda), lambda);
    if (i >= n / 2) {
      sum += est.scale();
      ++count;
    }
  }
  return sum / count;
}

TEST(FusionAdaptiveNoise, ConvergesToTheTrueNoiseRatio) {
  for (const double k : {4.0, 9.0}) {
    // Measurement noise dominating, and a prediction as uncertain as the reported noise.
    for (const double p : {0.0, 1.0}) {
      NisNoiseScale est(wide_options(), kGate, kDof);
      const double mean = run_linear_model(est, k, p, 4000, 7);
      EXPECT_NEAR(mean / k, 1.0, 0.1) << "k " << k << ", p " << p;
    }
  }
}

TEST(FusionAdaptiveNoise, ConsistentNoiseKeepsTheScaleNearOne) {
  for (const double p : {0.0, 1.0}) {
    NisNoiseScale est(wide_options(), kGate, kDof);
    const double mean = run_linear_model(est, 1.0, p, 4000, 11);
    EXPECT_GE(mean, 1.0);  // the floor
    EXPECT_LT(mean, 1.1) << "p " << p;
  }
}

TEST(FusionAdaptiveNoise, OverReportedNoiseStaysAtTheFloor) {
  // The odometry is half as noisy as it says: the scale does not sharpen the covariance below
  // min_scale (the NIS cannot tell a too large P from a too large R).
  NisNoiseScale est(wide_options(), kGate, kDof);
  run_linear_model(est, 0.5, 0.0, 2000, 3);
  EXPECT_EQ(est.scale(), 1.0);
}

TEST(FusionAdaptiveNoise, BoundedByTheGateOverTheDegreesOfFreedom) {
  AdaptiveNoiseOptions o;
  o.enabled = true;  // max_scale 0: gate / dof
  NisNoiseScale est(o, kGate, kDof);
  EXPECT_NEAR(est.upper_bound(), kGate / kDof, 1e-12);
  EXPECT_NEAR(est.upper_bound(), 3.74, 0.01);
  // Every update far outside the gate (an odometry that has lost track): bounded, no run-away.
  for (int i = 0; i < 1000; ++i) est.add(1e12, est.scale());
  EXPECT_DOUBLE_EQ(est.scale(), est.upper_bound());
  // One such outlier moves a consistent scale by at most (cap / dof - 1) / window.
  NisNoiseScale one(o, kGate, kDof);
  one.add(1e12, 1.0);
  EXPECT_NEAR(one.scale(), 1.0 + (kGate / kDof - 1.0) / o.window_updates, 1e-12);
}

TEST(FusionAdaptiveNoise, BadInputIsRefusedAndLeavesTheScale) {
  NisNoiseScale est(wide_options(), kGate, kDof);
  est.add(30.0, 1.0);
  const double before = est.scale();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(est.add(nan, 1.0), std::invalid_argument);
  EXPECT_THROW(est.add(inf, 1.0), std::invalid_argument);
  EXPECT_THROW(est.add(-1.0, 1.0), std::invalid_argument);
  EXPECT_THROW(est.add(6.0, nan), std::invalid_argument);
  EXPECT_THROW(est.add(6.0, 0.0), std::invalid_argument);
  EXPECT_EQ(est.scale(), before);
  EXPECT_EQ(est.samples(), 1u);
  EXPECT_THROW(NisNoiseScale(wide_options(), nan, kDof), std::invalid_argument);
  EXPECT_THROW(NisNoiseScale(wide_options(), kGate, 0), std::invalid_argument);
}

TEST(FusionAdaptiveNoise, OptionsOutsideTheirSenseAreRefused) {
  auto refused = [](auto change, const char* field) {
    FusionOptions o;
    change(o.adaptive_vo_noise);
    try {
      o.validate();
      ADD_FAILURE() << field << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  refused([](AdaptiveNoiseOptions& a) { a.window_updates = 0.5; }, "adaptive_vo_noise_window");
  refused([](AdaptiveNoiseOptions& a) { a.window_updates = std::nan(""); },
          "adaptive_vo_noise_window");
  refused([](AdaptiveNoiseOptions& a) { a.min_scale = 0.0; }, "adaptive_vo_noise_min_scale");
  refused([](AdaptiveNoiseOptions& a) { a.max_scale = 0.5; }, "adaptive_vo_noise_max_scale");
  refused([](AdaptiveNoiseOptions& a) { a.max_scale = -1.0; }, "adaptive_vo_noise_max_scale");
}

// The whole filter on a simulated flight (IMU at its densities, relative poses at 20 Hz) whose
// odometry is `k` times noisier (in variance) than the covariance it reports.
struct FilterRun {
  double final_scale = 0.0;
  FusionCounters counters;
};
FilterRun fly_with_misreported_odometry(double k, bool adaptive, std::uint64_t seed) {
  lab::SimulationOptions sim;
  sim.duration_s = 40.0;
  sim.imu_rate_hz = 200.0;
  FusionOptions fusion;
  fusion.T_body_cam = sim.T_body_cam;
  fusion.reorder_window_s = 0.0;
  fusion.adaptive_vo_noise = wide_options();
  fusion.adaptive_vo_noise.enabled = adaptive;
  // The run is drawn with sigma sqrt(k) times the nominal one, and reports the nominal.
  lab::SimulationOptions noisy = sim;
  noisy.vo_sigma_p_m *= std::sqrt(k);
  noisy.vo_sigma_rot_deg *= std::sqrt(k);
  std::mt19937_64 rng(seed);
  const lab::SimulatedFlight flight(seed);
  lab::SimulatedRun run = lab::simulate_run(flight, noisy, fusion, rng);
  const Matrix6d reported = lab::simulated_vo_covariance(sim);
  for (auto& m : run.odometry) m.covariance = reported;
  FusionEngine engine(fusion);
  engine.initialize(lab::true_state(flight, run, 0, sim.imu_rate_hz));
  std::size_t i = 0;
  for (const auto& m : run.odometry) {
    while (i < run.imu.size() && run.imu[i].t_ns <= m.t_ns) engine.add_imu(run.imu[i++]);
    engine.add_relative_pose(m);
    (void)engine.flush(false);
  }
  return {engine.vo_noise_scale(), engine.counters()};
}

TEST(FusionAdaptiveNoise, FilterFindsTheOdometrysTrueNoise) {
  for (const double k : {1.0, 4.0, 16.0}) {
    const FilterRun off = fly_with_misreported_odometry(k, false, 5);
    const FilterRun on = fly_with_misreported_odometry(k, true, 5);
    EXPECT_EQ(off.final_scale, 1.0);
    if (k == 1.0) {
      EXPECT_LT(on.final_scale, 1.3);
    } else {
      EXPECT_NEAR(on.final_scale / k, 1.0, 0.3) << "k " << k;
      // The gate refuses much of the misreported odometry; the scaled covariance lets it in.
      EXPECT_LT(on.counters.updates_gated, off.counters.updates_gated) << "k " << k;
    }
    EXPECT_NEAR(on.counters.mean_nis(), 6.0, 1.5) << "k " << k;
    EXPECT_GT(on.counters.vo_noise_scale_max, 0.0);
  }
}

TEST(FusionAdaptiveNoise, InvalidMeasurementDoesNotReachTheScale) {
  lab::SimulationOptions sim;
  sim.duration_s = 5.0;
  FusionOptions fusion;
  fusion.T_body_cam = sim.T_body_cam;
  fusion.reorder_window_s = 0.0;
  fusion.adaptive_vo_noise = wide_options();
  std::mt19937_64 rng(2);
  const lab::SimulatedFlight flight(2);
  lab::SimulatedRun run = lab::simulate_run(flight, sim, fusion, rng);
  for (auto& m : run.odometry) m.covariance *= 1.0 / 9.0;  // a scale to learn
  Eigen::Vector3d nan_t = run.odometry[40].T_ref_cur.translation();
  nan_t.x() = std::numeric_limits<double>::quiet_NaN();
  run.odometry[40].T_ref_cur = SE3(run.odometry[40].T_ref_cur.so3(), nan_t);
  FusionEngine engine(fusion);
  engine.initialize(lab::true_state(flight, run, 0, sim.imu_rate_hz));
  std::size_t i = 0;
  for (std::size_t j = 0; j < run.odometry.size(); ++j) {
    const auto& m = run.odometry[j];
    while (i < run.imu.size() && run.imu[i].t_ns <= m.t_ns) engine.add_imu(run.imu[i++]);
    const double before = engine.vo_noise_scale();
    engine.add_relative_pose(m);
    (void)engine.flush(false);
    if (j == 40) {
      EXPECT_EQ(engine.counters().updates_invalid, 1u);
      EXPECT_EQ(engine.vo_noise_scale(), before);  // the NaN update did not move it
    }
  }
  EXPECT_EQ(engine.counters().updates_invalid, 1u);
  EXPECT_GT(engine.vo_noise_scale(), 3.0);
}

}  // namespace
}  // namespace kestrel::fusion
