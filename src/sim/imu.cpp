// Ideal IMU samples (specific force and angular rate in the body frame) from a trajectory.
#include "kestrel/sim/imu.hpp"

#include <cmath>
#include <stdexcept>

namespace kestrel::sim {

io::ImuSample ideal_imu_sample(const KinematicState& state, TimeNs t_ns,
                               const Eigen::Vector3d& g_world) {
  io::ImuSample s;
  s.t_ns = t_ns;
  s.gyro_rad_s = state.omega_body;
  s.accel_m_s2 = state.T_world_body.so3().inverse() * (state.a_world - g_world);
  return s;
}

std::vector<io::ImuSample> ideal_imu_samples(const SmoothTrajectory& trajectory, TimeNs start_ns,
                                             TimeNs end_ns, double rate_hz,
                                             const Eigen::Vector3d& g_world) {
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) {
    throw std::invalid_argument("ideal_imu_samples: rate must be positive");
  }
  const auto period_ns = static_cast<TimeNs>(std::llround(1e9 / rate_hz));
  if (period_ns <= 0) throw std::invalid_argument("ideal_imu_samples: rate too high");
  std::vector<io::ImuSample> out;
  if (end_ns >= start_ns)
    out.reserve(static_cast<std::size_t>((end_ns - start_ns) / period_ns + 1));
  for (TimeNs t = start_ns; t <= end_ns; t += period_ns) {
    out.push_back(ideal_imu_sample(trajectory.state(ns_to_s(t - start_ns)), t, g_world));
  }
  return out;
}

}  // namespace kestrel::sim
