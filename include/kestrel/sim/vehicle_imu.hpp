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

  /// A slow, temperature-like bias drift on top of the random walk: the biases move by
  /// amplitude * (1 - exp(-t / time_constant_s)) along a fixed direction per sensor drawn from
  /// the seed (an IMU warming up after power-on), t from the first sample.
  void set_warm_up_drift(double gyro_amplitude_rad_s, double accel_amplitude_m_s2,
                         double time_constant_s);

  /// The noise-free reading (specific force and rate in the IMU frame).
  [[nodiscard]] io::ImuSample ideal_sample(const QuadrotorState& state,
                                           double gravity_m_s2 = 9.81) const;

  /// The random-walk biases (without the warm-up drift).
  [[nodiscard]] const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }
  [[nodiscard]] const Eigen::Vector3d& accel_bias() const { return accel_bias_; }
  /// The warm-up drift at time t_ns (added to the biases above).
  [[nodiscard]] Eigen::Vector3d gyro_drift(TimeNs t_ns) const;
  [[nodiscard]] Eigen::Vector3d accel_drift(TimeNs t_ns) const;
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
  TimeNs first_t_ns_ = 0;
  Eigen::Vector3d gyro_drift_ = Eigen::Vector3d::Zero();  // amplitude * direction
  Eigen::Vector3d accel_drift_ = Eigen::Vector3d::Zero();
  double drift_time_constant_s_ = 1.0;
};

}  // namespace kestrel::sim
