// Values that cross the control module's edges: the state estimate the controller flies on,
// the reference it tracks, the attitude/thrust command it produces and the four RC channels
// that carry that command to the flight controller. World frame z-up, body frame x forward,
// y left, z up (docs/control.md), time in int64 nanoseconds.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::control {

/// Standard gravity magnitude (m/s^2); the world's gravity vector is (0, 0, -kGravity).
inline constexpr double kGravity = 9.81;

/// What the controller needs of the estimator (the EKF's state maps onto it directly; in
/// tests the true state of the simulated vehicle stands in for it).
struct VehicleStateEstimate {
  TimeNs t_ns = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< m, body origin in the world
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();  ///< m/s
  SO3 R_world_body;
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();  ///< rad/s (informational)
  /// The IMU's specific force in the body frame (m/s^2, accelerometer minus its bias
  /// estimate): what the disturbance observer compares with the commanded thrust. Empty where
  /// the estimator has none (the observer then holds its estimate).
  std::optional<Eigen::Vector3d> specific_force_body;
};

/// Position, velocity and attitude all finite (what the controller may act on).
inline bool finite_estimate(const VehicleStateEstimate& e) {
  return e.p_world.allFinite() && e.v_world.allFinite() &&
         e.R_world_body.unit_quaternion().coeffs().allFinite();
}

/// The estimator's health as the safety supervisor sees it.
struct EstimatorHealth {
  bool estimate_valid = true;        ///< false: the filter has failed (diverged, not initialised)
  TimeNs last_vision_update_ns = 0;  ///< time of the last accepted odometry measurement
  double position_sigma_m = 0.0;     ///< sqrt of the largest position variance (0 if unknown)
};

/// A point of the desired path with feed-forward terms.
struct PositionReference {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();  ///< velocity feed-forward
  Eigen::Vector3d a_world = Eigen::Vector3d::Zero();  ///< acceleration feed-forward
  double yaw_rad = 0.0;
  double yaw_rate_rad_s = 0.0;  ///< yaw-rate feed-forward
};

/// What an attitude-stabilising flight controller accepts: tilt as ZYX Euler angles relative
/// to the current heading (R = Rz(yaw) Ry(pitch) Rx(roll)), a yaw rate and the collective
/// thrust. Positive roll lowers the right (-y) side, positive pitch lowers the nose, so that
/// +roll accelerates towards -y and +pitch towards +x (body FLU).
struct AttitudeThrustCommand {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rate_rad_s = 0.0;  ///< about the world z-axis (counter-clockwise seen from above)
  double thrust_N = 0.0;        ///< collective thrust along body z
};

/// Pulse widths (microseconds) of the four RC channels in the flight controller's input
/// order: aileron (roll), elevator (pitch), throttle, rudder (yaw rate). "AETR".
struct PwmChannels {
  static constexpr int kRoll = 0;
  static constexpr int kPitch = 1;
  static constexpr int kThrottle = 2;
  static constexpr int kYaw = 3;
  std::array<int, 4> us{1500, 1500, 1000, 1500};
  friend bool operator==(const PwmChannels&, const PwmChannels&) = default;
};

/// Wraps an angle to (-pi, pi].
double wrap_angle(double rad);
/// Heading (ZYX yaw) of a body orientation: the world-frame angle of the body x-axis.
double yaw_of(const SO3& R_world_body);

}  // namespace kestrel::control
