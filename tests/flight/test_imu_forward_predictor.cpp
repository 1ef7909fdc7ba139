// The output predictor carries a fused state to the present on the IMU: with exact IMU
// samples of a known motion it must land on the true state, and it must start over from each
// new fused state.
#include <gtest/gtest.h>

#include "kestrel/flight/imu_forward_predictor.hpp"

namespace kestrel::flight {
namespace {

constexpr double kG = 9.81;

/// A body spinning about a tilted axis at a constant rate while accelerating at a constant
/// world acceleration: exact pose, velocity and IMU readings at any time.
struct KnownMotion {
  Eigen::Vector3d p0{1.0, -2.0, 1.5}, v0{0.3, 0.1, -0.2}, a_world{0.4, -0.3, 0.2};
  Eigen::Vector3d omega_body{0.2, -0.4, 0.9};
  SO3 R0 = SO3::exp(Eigen::Vector3d(0.1, 0.2, -0.3));
  Eigen::Vector3d gyro_bias{0.01, -0.02, 0.005}, accel_bias{0.05, 0.02, -0.04};

  SO3 R(double t) const { return R0 * SO3::exp(omega_body * t); }
  Eigen::Vector3d p(double t) const { return p0 + v0 * t + 0.5 * a_world * t * t; }
  Eigen::Vector3d v(double t) const { return v0 + a_world * t; }
  io::ImuSample imu(TimeNs t_ns) const {
    const double t = ns_to_s(t_ns);
    io::ImuSample s;
    s.t_ns = t_ns;
    s.gyro_rad_s = omega_body + gyro_bias;
    s.accel_m_s2 = R(t).inverse() * (a_world - Eigen::Vector3d(0, 0, -kG)) + accel_bias;
    return s;
  }
  fusion::FusedState fused(TimeNs t_ns) const {
    const double t = ns_to_s(t_ns);
    fusion::FusedState f;
    f.t_ns = t_ns;
    f.state.t_ns = t_ns;
    f.state.p_world = p(t);
    f.state.v_world = v(t);
    f.state.q_world_body = R(t).unit_quaternion();
    f.state.gyro_bias_rad_s = gyro_bias;
    f.state.accel_bias_m_s2 = accel_bias;
    return f;
  }
};

TEST(ImuForwardPredictor, NothingBeforeTheFirstFusedState) {
  ImuForwardPredictor predictor(kG);
  EXPECT_FALSE(predictor.predict().has_value());
  EXPECT_EQ(predictor.lag_s(), 0.0);
}

TEST(ImuForwardPredictor, CarriesTheFusedStateToTheNewestSampleOfAKnownMotion) {
  const KnownMotion m;
  ImuForwardPredictor predictor(kG);
  const TimeNs step = 1'000'000;  // 1 kHz
  for (TimeNs t = 0; t <= 100 * step; t += step) predictor.add_imu(m.imu(t));
  predictor.set_fused(m.fused(40 * step));  // the filter lags 60 ms
  EXPECT_NEAR(predictor.lag_s(), 0.060, 1e-12);
  const auto e = predictor.predict();
  ASSERT_TRUE(e.has_value());
  const double t = 0.100;
  EXPECT_EQ(e->t_ns, 100 * step);
  // The filter's step is exact for constant world acceleration and body rate, up to the
  // attitude's change within each step (second order in dt): micrometres over 60 ms.
  EXPECT_LT((e->p_world - m.p(t)).norm(), 2e-5);
  EXPECT_LT((e->v_world - m.v(t)).norm(), 5e-4);
  EXPECT_LT((e->R_world_body.inverse() * m.R(t)).log().norm(), 1e-9);
  EXPECT_LT((e->omega_body - m.omega_body).norm(), 1e-12);
}

TEST(ImuForwardPredictor, StartsOverFromEachFusedStateAndDropsOlderSamples) {
  const KnownMotion m;
  ImuForwardPredictor predictor(kG);
  const TimeNs step = 1'000'000;
  for (TimeNs t = 0; t <= 50 * step; t += step) predictor.add_imu(m.imu(t));
  fusion::FusedState off = m.fused(10 * step);
  off.state.p_world += Eigen::Vector3d(1.0, 0.0, 0.0);  // a fused state 1 m off
  predictor.set_fused(off);
  EXPECT_NEAR((predictor.predict()->p_world - m.p(0.05)).x(), 1.0, 1e-4);
  predictor.set_fused(m.fused(50 * step));  // the newest: nothing left to integrate
  EXPECT_EQ(predictor.lag_s(), 0.0);
  EXPECT_LT((predictor.predict()->p_world - m.p(0.05)).norm(), 1e-12);
  // An out-of-order sample is ignored.
  predictor.add_imu(m.imu(20 * step));
  EXPECT_LT((predictor.predict()->p_world - m.p(0.05)).norm(), 1e-12);
}

TEST(ImuForwardPredictor, GivesTheBiasCorrectedMeanSpecificForceOfTheLastControlPeriod) {
  const KnownMotion m;
  ImuForwardPredictor predictor(kG);
  const TimeNs step = 1'000'000;
  // Alternating +-1 m/s^2 on x over the 1 kHz samples: the 5 ms mean of the newest five
  // (t = 96..100 ms: three +1 and two -1) is +0.2 m/s^2, not the newest sample alone.
  for (TimeNs t = 0; t <= 100 * step; t += step) {
    io::ImuSample s = m.imu(t);
    s.accel_m_s2.x() += (t / step) % 2 == 0 ? 1.0 : -1.0;
    predictor.add_imu(s);
  }
  predictor.set_fused(m.fused(40 * step));
  const auto e = predictor.predict();
  ASSERT_TRUE(e.has_value() && e->specific_force_body.has_value());
  // The true specific force changes with the attitude within the window: tenths of a mm/s^2.
  const Eigen::Vector3d truth = m.imu(98 * step).accel_m_s2 - m.accel_bias;
  EXPECT_NEAR(e->specific_force_body->x() - truth.x(), 0.2, 5e-3);
  EXPECT_NEAR(e->specific_force_body->y(), truth.y(), 5e-3);
  EXPECT_NEAR(e->specific_force_body->z(), truth.z(), 5e-3);
}

}  // namespace
}  // namespace kestrel::flight
