// Random nominal states and IMU readings for the fusion's Jacobian and covariance tests
// (test_ekf_jacobians.cpp, test_time_offset.cpp, test_covariance_steps.cpp).
#pragma once

#include <random>

#include "kestrel/fusion/stochastic_cloning_ekf.hpp"

namespace kestrel::fusion::random_states {

/// A random state: positions of metres, any attitudes, biases of their usual size. With
/// `offset_and_rates`, also a camera-IMU time offset of tens of ms and fast rates (1.5 rad/s per
/// axis) at the current and the clone time, so that frames shifted by the offset differ visibly
/// from unshifted ones; the draws of the other fields are the same either way. With
/// `extrinsic`, also an odometry-IMU rotation of ~17 deg per axis (drawn last).
inline NominalState random_state(std::mt19937_64& rng, bool offset_and_rates = false,
                                 bool extrinsic = false) {
  std::normal_distribution<double> n(0.0, 1.0);
  auto v3 = [&](double s) {
    // One draw per statement: the order of draws is fixed (it is not within one call).
    const double x = n(rng);
    const double y = n(rng);
    const double z = n(rng);
    return Eigen::Vector3d(s * x, s * y, s * z);
  };
  NominalState x;
  x.p_world = v3(2.0);
  x.q_world_body = SO3::exp(v3(1.0)).unit_quaternion();
  x.v_world = v3(1.0);
  x.gyro_bias_rad_s = v3(0.02);
  x.accel_bias_m_s2 = v3(0.1);
  x.p_clone_world = x.p_world + v3(0.3);
  x.q_world_clone = SO3::exp(v3(1.0)).unit_quaternion();
  if (offset_and_rates) {
    x.time_offset_s = 0.03 * n(rng);
    x.omega_body = v3(1.5);
    x.v_clone_body = v3(1.0);
    x.omega_clone_body = v3(1.5);
  }
  if (extrinsic) x.q_body_odom = SO3::exp(v3(0.3)).unit_quaternion();
  return x;
}

/// A random IMU reading: rates of 1.5 rad/s and accelerations of 3 m/s^2 per axis about 1 g.
inline ImuReading random_reading(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return {Eigen::Vector3d(n(rng), n(rng), n(rng)) * 1.5,
          Eigen::Vector3d(n(rng), n(rng), n(rng)) * 3.0 + Eigen::Vector3d(0, 0, 9.81)};
}

}  // namespace kestrel::fusion::random_states
