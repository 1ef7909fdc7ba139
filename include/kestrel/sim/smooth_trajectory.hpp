// Smooth ground-truth trajectories with analytic derivatives: for any time t, the pose
// T_world_body, linear velocity and acceleration (world frame), angular velocity and angular
// acceleration (body frame). Named trajectories ("still", "forward", "circle", "orbit", "rpy",
// "sway", "handheld") start at a scene's start pose. The body frame is x forward, y left,
// z up (a level body looks horizontally along its x); the camera is mounted looking forward.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/io/trajectory.hpp"
#include "kestrel/sim/catalogue.hpp"

namespace kestrel::sim {

/// A scalar function of time with its first two derivatives: f(t), f'(t), f''(t).
struct Jet {
  double value = 0.0;
  double rate = 0.0;
  double accel = 0.0;
};
using ScalarFunction = std::function<Jet(double t_s)>;

/// offset + slope * t + sum_k amplitude_k * sin(2 pi frequency_k t + phase_k).
struct SinusoidTerm {
  double amplitude = 0.0;
  double frequency_hz = 0.0;
  double phase_rad = 0.0;
};
ScalarFunction sum_of_sinusoids(double offset, double slope, std::vector<SinusoidTerm> terms);
inline ScalarFunction constant_function(double value) { return sum_of_sinusoids(value, 0.0, {}); }

/// The full kinematic state of the body at one instant.
struct KinematicState {
  SE3 T_world_body;
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();     ///< m/s
  Eigen::Vector3d a_world = Eigen::Vector3d::Zero();     ///< m/s^2
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();  ///< rad/s, in the body frame
  Eigen::Vector3d alpha_body = Eigen::Vector3d::Zero();  ///< rad/s^2, d(omega_body)/dt
};

/// T_world_body(t) = T_world_origin * (R(t), p(t)), with p(t) = (x, y, z)(t) and
/// R(t) = Rz(yaw) Ry(pitch) Rx(roll) (roll about body x, pitch about body y, yaw about the
/// origin frame's z), all six given as smooth scalar functions with their derivatives.
/// Time is in seconds since the trajectory's start.
class SmoothTrajectory {
 public:
  SmoothTrajectory(std::string name, const SE3& T_world_origin,
                   std::array<ScalarFunction, 3> position_m,
                   std::array<ScalarFunction, 3> roll_pitch_yaw_rad);

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const SE3& T_world_origin() const { return T_world_origin_; }

  [[nodiscard]] KinematicState state(double t_s) const;
  [[nodiscard]] SE3 T_world_body(double t_s) const { return state(t_s).T_world_body; }

  /// Poses at the given times: T_world_body(t) * T_body_sensor (time ns mapped to the
  /// trajectory's seconds as (t_ns - start_ns) * 1e-9).
  [[nodiscard]] Trajectory sample(const std::vector<TimeNs>& times_ns, TimeNs start_ns,
                                  const SE3& T_body_sensor = SE3()) const;

 private:
  std::string name_;
  SE3 T_world_origin_;
  std::array<ScalarFunction, 3> position_;
  std::array<ScalarFunction, 3> rpy_;
};

/// The standard camera mount: the optical frame (x right, y down, z forward) looking along
/// body x, at the body origin: R_body_cam columns (0,-1,0), (0,0,-1), (1,0,0).
SE3 forward_camera_mount();

/// The named trajectories with their descriptions.
const std::vector<CatalogueEntry>& trajectory_catalogue();

/// Builds a named trajectory starting at T_world_start (at t = 0 the body is exactly there).
/// `seed` drives the random ones ("handheld"); the others ignore it. Throws InputError naming the
/// valid trajectories for an unknown name.
SmoothTrajectory make_trajectory(std::string_view name, const SE3& T_world_start,
                                 std::uint64_t seed = 1);

}  // namespace kestrel::sim
