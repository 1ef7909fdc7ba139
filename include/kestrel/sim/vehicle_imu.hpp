// IMU samples from the simulated vehicle's true motion, with white noise and random-walk
// biases from an EuRoC-style sensor YAML (imu0/sensor.yaml: continuous-time densities), the
// IMU mounted at T_body_imu (lever arm included). Deterministic from a seed.
#pragma once

#include <cstdint>
#include <random>

#include "kestrel/io/euroc.hpp"
#include "kestrel/sim/quadrotor.hpp"

namespace kestrel::sim {

/// The noise of a Naza-class MEMS IMU (MPU-6000 data-sheet densities, sampled at 1 kHz as in
/// thesis 4.4); config/imu_default.yaml holds the same in EuRoC's format.
io::ImuNoise default_vehicle_imu_noise();

class VehicleImuSimulator {
 public:
  /// Initial biases are drawn with these standard deviations (per axis).
  VehicleImuSimulator(io::ImuNoise noise, std::uint64_t seed,
                      double initial_gyro_bias_sigma_rad_s = 2e-3,
                      double initial_accel_bias_sigma_m_s2 = 3e-2);

  /// What the IMU reads at state.t_ns. Biases random-walk over the time since the previous
  /// sample; the white noise's discrete sigma is density * sqrt(rate_hz).
  io::ImuSample sample(const QuadrotorState& state);

  /// The noise-free reading (specific force and rate in the IMU frame).
  [[nodiscard]] io::ImuSample ideal_sample(const QuadrotorState& state, double gravity_m_s2 = 9.81) const;

  [[nodiscard]] const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }
  [[nodiscard]] const Eigen::Vector3d& accel_bias() const { return accel_bias_; }
  [[nodiscard]] const io::ImuNoise& noise() const { return noise_; }

 private:
  Eigen::Vector3d gaussian3();

  io::ImuNoise noise_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Eigen::Vector3d gyro_bias_;
  Eigen::Vector3d accel_bias_;
  bool has_last_ = false;
  TimeNs last_t_ns_ = 0;
};

}  // namespace kestrel::sim
