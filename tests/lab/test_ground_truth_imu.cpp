// The IMU synthesised from a ground-truth trajectory (fuse-eval's control experiment): the
// spline through the samples, the IMU it implies, and the noise it adds.
#include <gtest/gtest.h>

#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "kestrel/lab/fusion_simulation.hpp"
#include "kestrel/lab/ground_truth_imu.hpp"

namespace kestrel::lab {
namespace {

using Eigen::Vector3d;

constexpr TimeNs kGtPeriod = 25'000'000;  // 40 Hz, as EuRoC's gt0 here
constexpr TimeNs kImuPeriod = 5'000'000;  // 200 Hz

std::vector<TimeNs> imu_stamps(TimeNs t0, TimeNs t1) {
  std::vector<TimeNs> out;
  for (TimeNs t = t0; t <= t1; t += kImuPeriod) out.push_back(t);
  return out;
}

// Samples of p = p0 + v0 t + a t^2 / 2 and R = R0 exp(w t) (a constant body rate).
std::vector<GroundTruthSample> constant_acceleration(const Vector3d& a, const Vector3d& w, int n) {
  std::vector<GroundTruthSample> gt(static_cast<std::size_t>(n));
  const Vector3d p0(1.0, -2.0, 0.5), v0(0.3, 0.1, -0.2);
  const SO3 R0 = SO3::exp(Vector3d(0.1, -0.2, 0.3));
  for (int i = 0; i < n; ++i) {
    const double t = ns_to_s(i * kGtPeriod);
    gt[static_cast<std::size_t>(i)].t_ns = i * kGtPeriod;
    gt[static_cast<std::size_t>(i)].T_world_body =
        SE3(R0 * SO3::exp(w * t), p0 + v0 * t + 0.5 * a * t * t);
  }
  return gt;
}

TEST(GroundTruthSpline, PassesThroughTheSamplesAndRecoversAConstantAcceleration) {
  const Vector3d a(0.8, -1.5, 2.0), w(0.2, -0.4, 0.9);
  const auto gt = constant_acceleration(a, w, 121);  // 3 s
  const GroundTruthSpline spline(gt);
  for (const auto& g : gt) {
    EXPECT_LT((spline.position(g.t_ns) - g.T_world_body.translation()).norm(), 1e-9);
    EXPECT_LT((spline.orientation(g.t_ns).inverse() * g.T_world_body.so3()).log().norm(), 1e-9);
  }
  // The natural end conditions (zero acceleration at the ends) fade within a few samples: in
  // the middle half the spline has the trajectory's acceleration, velocity and rate.
  for (TimeNs t = 30 * kGtPeriod; t <= 90 * kGtPeriod; t += kImuPeriod) {
    const double s = ns_to_s(t);
    EXPECT_LT((spline.acceleration(t) - a).norm(), 1e-6) << "t " << s;
    EXPECT_LT((spline.velocity(t) - (Vector3d(0.3, 0.1, -0.2) + a * s)).norm(), 1e-6) << "t " << s;
    EXPECT_LT((spline.body_rate(t) - w).norm(), 1e-9) << "t " << s;
  }
}

TEST(GroundTruthSpline, RejectsTooFewOrUnorderedSamples) {
  auto gt = constant_acceleration(Vector3d::Zero(), Vector3d::Zero(), 5);
  EXPECT_THROW(GroundTruthSpline(std::vector<GroundTruthSample>(gt.begin(), gt.begin() + 2)),
               InputError);
  gt[3].t_ns = gt[2].t_ns;
  EXPECT_THROW(GroundTruthSpline{gt}, InputError);
}

// On a simulated flight (analytic derivatives) sampled at 40 Hz, the noise-free synthetic IMU
// is the ideal IMU up to the spline's approximation, and dead reckoning on it with the filter's
// own integrator follows the flight: the control experiment's IMU is what it claims to be.
TEST(GroundTruthImu, NoiseFreeImuOfASampledFlightDeadReckonsIt) {
  const SimulatedFlight flight(3);
  std::vector<GroundTruthSample> gt;
  for (TimeNs t = 0; t <= s_to_ns(10.0); t += kGtPeriod) {
    GroundTruthSample g;
    g.t_ns = t;
    g.T_world_body = flight.at(ns_to_s(t)).T_world_body;
    gt.push_back(g);
  }
  GroundTruthImuOptions opt;
  opt.noise_on = false;
  std::mt19937_64 rng(1);
  const auto imu = imu_from_ground_truth(gt, imu_stamps(0, s_to_ns(10.0)), opt, rng);
  ASSERT_EQ(imu.size(), 2001u);
  const Vector3d g_world(0.0, 0.0, -opt.gravity_m_s2);
  double se_gyro = 0.0, se_accel = 0.0;
  int n = 0;
  for (const auto& s : imu) {
    if (s.t_ns < s_to_ns(1.0) || s.t_ns > s_to_ns(9.0)) continue;  // the spline's ends
    const io::ImuSample ideal = ideal_imu_sample(flight.at(ns_to_s(s.t_ns)), s.t_ns, g_world);
    se_gyro += (s.gyro_rad_s - ideal.gyro_rad_s).squaredNorm();
    se_accel += (s.accel_m_s2 - ideal.accel_m_s2).squaredNorm();
    ++n;
  }
  const double rms_gyro = std::sqrt(se_gyro / n), rms_accel = std::sqrt(se_accel / n);
  std::cout << "synthetic vs ideal IMU: gyro rms " << rms_gyro << " rad/s, accel rms " << rms_accel
            << " m/s^2\n";
  EXPECT_LT(rms_gyro, 0.02);  // a constant rate between samples: the mean, not the wiggle
  EXPECT_LT(rms_accel, 0.05);
  // 2 s of dead reckoning from the true state at 4 s (the length of the fusion's gap), on the
  // synthetic IMU and, for the integrator's own error, on the ideal IMU of the analytic flight.
  auto dead_reckoning = [&](const std::vector<io::ImuSample>& samples, const Vector3d& v0) {
    fusion::NominalState x;
    const FlightPoint p0 = flight.at(4.0);
    x.t_ns = s_to_ns(4.0);
    x.p_world = p0.T_world_body.translation();
    x.q_world_body = p0.T_world_body.unit_quaternion();
    x.v_world = v0;
    double max_error = 0.0;
    for (std::size_t k = 800; samples[k + 1].t_ns <= s_to_ns(6.0); ++k) {  // [800]: 4 s
      const fusion::ImuReading m{0.5 * (samples[k].gyro_rad_s + samples[k + 1].gyro_rad_s),
                                 0.5 * (samples[k].accel_m_s2 + samples[k + 1].accel_m_s2)};
      x = fusion::StochasticCloningEkf::propagate_nominal(x, m, ns_to_s(kImuPeriod), g_world);
      x.t_ns = samples[k + 1].t_ns;
      if (x.t_ns % kGtPeriod == 0) {  // at the ground-truth samples, which the spline holds
        const auto& g = gt[static_cast<std::size_t>(x.t_ns / kGtPeriod)];
        max_error = std::max(max_error, (x.p_world - g.T_world_body.translation()).norm());
      }
    }
    return max_error;
  };
  std::vector<io::ImuSample> ideal;
  for (const auto& s : imu)
    ideal.push_back(ideal_imu_sample(flight.at(ns_to_s(s.t_ns)), s.t_ns, g_world));
  ASSERT_EQ(imu[800].t_ns, s_to_ns(4.0));
  const double synthetic_error = dead_reckoning(imu, gt[160].v_world);  // the spline's velocity
  const double ideal_error = dead_reckoning(ideal, flight.at(4.0).v_world);
  std::cout << "dead reckoning over 2 s, max error: synthetic IMU " << synthetic_error * 1e3
            << " mm, ideal IMU " << ideal_error * 1e3 << " mm\n";
  EXPECT_LT(ideal_error, 1e-3);      // the filter's midpoint integrator (measured 0.05 mm)
  EXPECT_LT(synthetic_error, 1e-3);  // the spline's (measured 0.2 mm)
  const FlightPoint p0 = flight.at(4.0);
  EXPECT_LT((gt[160].v_world - p0.v_world).norm(), 0.01);  // the spline's velocity
}

// With the random walks off and a known bias, the samples differ from the noise-free ones by
// the bias plus white noise of density / sqrt(dt); the ground truth is given the biases.
TEST(GroundTruthImu, AddsTheSensorYamlsNoiseAndBias) {
  auto gt = constant_acceleration(Vector3d(0.5, 0.0, -0.3), Vector3d(0.0, 0.3, 0.1), 801);  // 20 s
  gt.front().has_bias = true;
  gt.front().gyro_bias = Vector3d(0.01, -0.02, 0.03);
  gt.front().accel_bias = Vector3d(-0.1, 0.05, 0.2);
  auto gt_clean = gt;
  GroundTruthImuOptions opt;
  opt.noise.gyro_walk = 0.0;
  opt.noise.accel_walk = 0.0;
  std::mt19937_64 rng(7);
  const auto stamps = imu_stamps(0, 20 * 1'000'000'000LL);
  const auto noisy = imu_from_ground_truth(gt, stamps, opt, rng);
  GroundTruthImuOptions clean_opt = opt;
  clean_opt.noise_on = false;
  const auto clean = imu_from_ground_truth(gt_clean, stamps, clean_opt, rng);
  ASSERT_EQ(noisy.size(), clean.size());
  Eigen::Vector3d mean_g = Vector3d::Zero(), mean_a = Vector3d::Zero();
  Eigen::Vector3d sq_g = Vector3d::Zero(), sq_a = Vector3d::Zero();
  const auto n = static_cast<double>(noisy.size() - 1);
  for (std::size_t i = 1; i < noisy.size(); ++i) {  // the first sample carries no white noise
    const Vector3d dg = noisy[i].gyro_rad_s - clean[i].gyro_rad_s;
    const Vector3d da = noisy[i].accel_m_s2 - clean[i].accel_m_s2;
    mean_g += dg / n;
    mean_a += da / n;
    sq_g += dg.cwiseProduct(dg) / n;
    sq_a += da.cwiseProduct(da) / n;
  }
  const double dt = ns_to_s(kImuPeriod);
  const double sg = opt.noise.gyro_noise / std::sqrt(dt),
               sa = opt.noise.accel_noise / std::sqrt(dt);
  for (int j = 0; j < 3; ++j) {
    // 4000 samples: the mean within ~4 standard errors, the sigma within 5 %.
    EXPECT_NEAR(mean_g(j), gt.front().gyro_bias(j), 4.0 * sg / std::sqrt(n));
    EXPECT_NEAR(mean_a(j), gt.front().accel_bias(j), 4.0 * sa / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(sq_g(j) - mean_g(j) * mean_g(j)), sg, 0.05 * sg);
    EXPECT_NEAR(std::sqrt(sq_a(j) - mean_a(j) * mean_a(j)), sa, 0.05 * sa);
  }
  for (const auto& g : gt) {
    EXPECT_TRUE(g.has_bias);
    EXPECT_EQ(g.gyro_bias, gt.front().gyro_bias);  // no walk
  }
}

TEST(GroundTruthImu, StampsOutsideTheGroundTruthAreAnError) {
  auto gt = constant_acceleration(Vector3d::Zero(), Vector3d::Zero(), 10);
  std::mt19937_64 rng(1);
  EXPECT_THROW(imu_from_ground_truth(gt, {-10, -5}, {}, rng), InputError);
  EXPECT_THROW(imu_from_ground_truth(gt, {10, 10, 20}, {}, rng), InputError);  // not increasing
}

}  // namespace
}  // namespace kestrel::lab
