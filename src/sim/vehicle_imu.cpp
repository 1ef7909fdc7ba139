// IMU simulation on the vehicle's true state: rigid-body kinematics to the IMU's mount, then
// biases (random walk) and white noise.
#include "kestrel/sim/vehicle_imu.hpp"

#include <cmath>
#include <random>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

io::ImuNoise default_vehicle_imu_noise() {
  io::ImuNoise n;
  n.gyro_noise_density = 8.7e-5;  // 0.005 deg/s/sqrt(Hz)
  n.gyro_random_walk = 2.0e-5;
  n.accel_noise_density = 3.9e-3;  // 400 ug/sqrt(Hz)
  n.accel_random_walk = 1.0e-3;
  n.rate_hz = 1000.0;
  return n;
}

VehicleImuSimulator::VehicleImuSimulator(io::ImuNoise noise, std::uint64_t seed,
                                         double initial_gyro_bias_sigma_rad_s,
                                         double initial_accel_bias_sigma_m_s2)
    : noise_(std::move(noise)), rng_(seed) {
  if (!(noise_.rate_hz > 0.0)) throw InputError("IMU noise: rate_hz must be positive");
  gyro_bias_ = initial_gyro_bias_sigma_rad_s * gaussian3();
  accel_bias_ = initial_accel_bias_sigma_m_s2 * gaussian3();
}

Eigen::Vector3d VehicleImuSimulator::gaussian3() {
  const double x = normal_(rng_);
  const double y = normal_(rng_);
  const double z = normal_(rng_);
  return {x, y, z};
}

io::ImuSample VehicleImuSimulator::ideal_sample(const QuadrotorState& s,
                                                double gravity_m_s2) const {
  const SO3 R_body_imu = noise_.T_body_imu.so3();
  const Eigen::Vector3d r = noise_.T_body_imu.translation();  // lever arm in the body
  const Eigen::Vector3d g_world(0.0, 0.0, -gravity_m_s2);
  // The landing gear's share of a touchdown (zero in flight) is felt like any acceleration.
  const Eigen::Vector3d f_body =
      s.R_world_body.inverse() * (s.a_world + s.contact_accel_world - g_world) +
      s.alpha_body.cross(r) + s.omega_body.cross(s.omega_body.cross(r));
  io::ImuSample out;
  out.t_ns = s.t_ns;
  out.gyro_rad_s = R_body_imu.inverse() * (s.omega_body + s.contact_rate_body);
  out.accel_m_s2 = R_body_imu.inverse() * f_body;
  return out;
}

void VehicleImuSimulator::set_warm_up_drift(double gyro_amplitude_rad_s,
                                            double accel_amplitude_m_s2, double time_constant_s) {
  if (!(gyro_amplitude_rad_s >= 0.0) || !(accel_amplitude_m_s2 >= 0.0) ||
      !(time_constant_s > 0.0)) {
    throw InputError("IMU drift: amplitudes must be >= 0 and the time constant positive");
  }
  // Directions from their own generator, seeded by one draw of the noise generator.
  std::mt19937_64 rng(rng_());
  std::normal_distribution<double> normal(0.0, 1.0);
  auto direction = [&] {
    const double x = normal(rng), y = normal(rng), z = normal(rng);
    return Eigen::Vector3d(x, y, z).normalized();
  };
  gyro_drift_ = gyro_amplitude_rad_s * direction();
  accel_drift_ = accel_amplitude_m_s2 * direction();
  drift_time_constant_s_ = time_constant_s;
}

Eigen::Vector3d VehicleImuSimulator::gyro_drift(TimeNs t_ns) const {
  if (!has_last_) return Eigen::Vector3d::Zero();
  return (1.0 - std::exp(-std::max(0.0, ns_to_s(t_ns - first_t_ns_)) / drift_time_constant_s_)) *
         gyro_drift_;
}

Eigen::Vector3d VehicleImuSimulator::accel_drift(TimeNs t_ns) const {
  if (!has_last_) return Eigen::Vector3d::Zero();
  return (1.0 - std::exp(-std::max(0.0, ns_to_s(t_ns - first_t_ns_)) / drift_time_constant_s_)) *
         accel_drift_;
}

io::ImuSample VehicleImuSimulator::sample(const QuadrotorState& state) {
  const double dt = has_last_ ? std::max(0.0, ns_to_s(state.t_ns - last_t_ns_)) : 0.0;
  if (!has_last_) first_t_ns_ = state.t_ns;
  has_last_ = true;
  last_t_ns_ = state.t_ns;
  if (dt > 0.0) {
    gyro_bias_ += noise_.gyro_random_walk * std::sqrt(dt) * gaussian3();
    accel_bias_ += noise_.accel_random_walk * std::sqrt(dt) * gaussian3();
  }
  io::ImuSample out = ideal_sample(state);
  const double sqrt_rate = std::sqrt(noise_.rate_hz);
  out.gyro_rad_s +=
      gyro_bias_ + gyro_drift(state.t_ns) + noise_.gyro_noise_density * sqrt_rate * gaussian3();
  out.accel_m_s2 +=
      accel_bias_ + accel_drift(state.t_ns) + noise_.accel_noise_density * sqrt_rate * gaussian3();
  return out;
}

}  // namespace kestrel::sim
