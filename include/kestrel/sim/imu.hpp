// Ideal (noise-free, bias-free) IMU samples from a smooth trajectory: what an accelerometer
// and a gyroscope rigidly attached to the body measure. Noise and biases belong to the filter
// tests that use them.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "kestrel/io/euroc.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {

/// Standard gravity in the z-up world: (0, 0, -9.81) m/s^2.
inline Eigen::Vector3d gravity_world() { return {0.0, 0.0, -9.81}; }

/// gyro = omega_body; accel = R_world_body^T (a_world - g_world) (specific force: a body at
/// rest reads +9.81 along the world's up direction expressed in the body).
io::ImuSample ideal_imu_sample(const KinematicState& state, TimeNs t_ns,
                               const Eigen::Vector3d& g_world = gravity_world());

/// Samples at start_ns + k * round(1e9 / rate_hz) for every such time in [start_ns, end_ns],
/// trajectory time (t_ns - start_ns) * 1e-9. Throws std::invalid_argument for rate <= 0.
std::vector<io::ImuSample> ideal_imu_samples(const SmoothTrajectory& trajectory, TimeNs start_ns,
                                             TimeNs end_ns, double rate_hz,
                                             const Eigen::Vector3d& g_world = gravity_world());

}  // namespace kestrel::sim
