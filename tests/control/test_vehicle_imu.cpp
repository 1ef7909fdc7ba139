// IMU samples from the vehicle's true motion: gravity at rest, noise statistics, determinism.
#include <gtest/gtest.h>

#include "kestrel/sim/vehicle_imu.hpp"

namespace kestrel::sim {
namespace {

TEST(VehicleImu, HoveringReadsGravityUpAndNoRate) {
  const QuadrotorParameters p;
  Quadrotor q(p, Quadrotor::hover_state(p, {0, 0, 1}, 0.7));
  q.step(0.001, Eigen::Vector4d::Constant(p.hover_rotor_speed_rad_s()));
  const VehicleImuSimulator imu(default_vehicle_imu_noise(), 1);
  const io::ImuSample s = imu.ideal_sample(q.state());
  EXPECT_NEAR((s.accel_m_s2 - Eigen::Vector3d(0, 0, 9.81)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(s.gyro_rad_s.norm(), 0.0, 1e-9);
}

TEST(VehicleImu, NoiseMatchesTheDensitiesAndIsDeterministic) {
  io::ImuNoise n = default_vehicle_imu_noise();
  n.gyro_random_walk = 0.0;
  n.accel_random_walk = 0.0;
  QuadrotorState s;
  s.p_world = {0, 0, 1};
  s.a_world = {0, 0, 0};
  VehicleImuSimulator a(n, 42, 0.0, 0.0), b(n, 42, 0.0, 0.0);
  const int count = 20000;
  double sum2_gyro = 0.0, sum2_accel = 0.0;
  for (int i = 0; i < count; ++i) {
    s.t_ns = static_cast<TimeNs>(i) * 1'000'000;
    const io::ImuSample x = a.sample(s), y = b.sample(s);
    ASSERT_EQ(x.gyro_rad_s, y.gyro_rad_s);
    sum2_gyro += x.gyro_rad_s.squaredNorm();
    sum2_accel += (x.accel_m_s2 - Eigen::Vector3d(0, 0, 9.81)).squaredNorm();
  }
  const double sigma_g = std::sqrt(sum2_gyro / (3 * count));
  const double sigma_a = std::sqrt(sum2_accel / (3 * count));
  EXPECT_NEAR(sigma_g / (n.gyro_noise_density * std::sqrt(n.rate_hz)), 1.0, 0.03);
  EXPECT_NEAR(sigma_a / (n.accel_noise_density * std::sqrt(n.rate_hz)), 1.0, 0.03);
}

TEST(VehicleImu, BiasesWalkAndShiftTheReadings) {
  io::ImuNoise n = default_vehicle_imu_noise();
  n.gyro_noise_density = 0.0;
  n.accel_noise_density = 0.0;
  VehicleImuSimulator imu(n, 7, 0.01, 0.1);
  QuadrotorState s;
  const Eigen::Vector3d b0 = imu.gyro_bias();
  EXPECT_GT(b0.norm(), 0.0);
  const io::ImuSample first = imu.sample(s);
  EXPECT_NEAR((first.gyro_rad_s - b0).norm(), 0.0, 1e-12);
  s.t_ns = 100'000'000'000;  // 100 s later: the bias has wandered about rw * sqrt(100)
  imu.sample(s);
  const double moved = (imu.gyro_bias() - b0).norm();
  EXPECT_GT(moved, 0.0);
  EXPECT_LT(moved, 10 * n.gyro_random_walk * 10.0 * std::sqrt(3.0));
}

TEST(VehicleImu, LeverArmAddsCentripetalAcceleration) {
  io::ImuNoise n = default_vehicle_imu_noise();
  n.T_body_imu = SE3(SO3(), Eigen::Vector3d(0.1, 0, 0));
  const VehicleImuSimulator imu(n, 3);
  QuadrotorState s;
  s.omega_body = {0, 0, 2.0};  // spinning at 2 rad/s about z, hovering
  const io::ImuSample x = imu.ideal_sample(s);
  EXPECT_NEAR(x.accel_m_s2.x(), -0.1 * 4.0, 1e-12);  // omega x (omega x r) = -w^2 r
  EXPECT_NEAR(x.accel_m_s2.z(), 9.81, 1e-12);
}

}  // namespace
}  // namespace kestrel::sim
