// SmoothTrajectory: pose and its first two derivatives from six smooth scalar functions, with
// the ZYX Euler kinematics written out (angular velocity and acceleration in the body frame).
#include "kestrel/sim/smooth_trajectory.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace kestrel::sim {

ScalarFunction sum_of_sinusoids(double offset, double slope, std::vector<SinusoidTerm> terms) {
  constexpr double kTwoPi = 6.28318530717958647692;
  return [offset, slope, terms = std::move(terms)](double t) {
    Jet j{offset + slope * t, slope, 0.0};
    for (const SinusoidTerm& k : terms) {
      const double w = kTwoPi * k.frequency_hz;
      const double arg = w * t + k.phase_rad;
      const double s = std::sin(arg);
      const double c = std::cos(arg);
      j.value += k.amplitude * s;
      j.rate += k.amplitude * w * c;
      j.accel -= k.amplitude * w * w * s;
    }
    return j;
  };
}

SmoothTrajectory::SmoothTrajectory(std::string name, const SE3& T_world_origin,
                                   std::array<ScalarFunction, 3> position_m,
                                   std::array<ScalarFunction, 3> roll_pitch_yaw_rad)
    : name_(std::move(name)),
      T_world_origin_(T_world_origin),
      position_(std::move(position_m)),
      rpy_(std::move(roll_pitch_yaw_rad)) {
  for (const auto& f : position_) {
    if (!f) throw std::invalid_argument("SmoothTrajectory: empty position function");
  }
  for (const auto& f : rpy_) {
    if (!f) throw std::invalid_argument("SmoothTrajectory: empty angle function");
  }
}

KinematicState SmoothTrajectory::state(double t_s) const {
  const Jet x = position_[0](t_s), y = position_[1](t_s), z = position_[2](t_s);
  const Jet roll = rpy_[0](t_s), pitch = rpy_[1](t_s), yaw = rpy_[2](t_s);

  // R = Rz(yaw) Ry(pitch) Rx(roll).
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(yaw.value, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch.value, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll.value, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();

  // omega_body = phi' e_x + Rx^T theta' e_y + Rx^T Ry^T psi' e_z (ZYX Euler kinematics).
  const double sphi = std::sin(roll.value), cphi = std::cos(roll.value);
  const double sth = std::sin(pitch.value), cth = std::cos(pitch.value);
  const double dphi = roll.rate, dth = pitch.rate, dpsi = yaw.rate;
  const double ddphi = roll.accel, ddth = pitch.accel, ddpsi = yaw.accel;

  KinematicState s;
  const Eigen::Matrix3d& R_wo = T_world_origin_.rotation_matrix();
  const Eigen::Vector3d p(x.value, y.value, z.value);
  s.T_world_body = T_world_origin_ * SE3(SO3::from_matrix(R), p);
  s.v_world = R_wo * Eigen::Vector3d(x.rate, y.rate, z.rate);
  s.a_world = R_wo * Eigen::Vector3d(x.accel, y.accel, z.accel);
  s.omega_body = {dphi - dpsi * sth, dth * cphi + dpsi * cth * sphi,
                  -dth * sphi + dpsi * cth * cphi};
  // Time derivative of the above, term by term.
  s.alpha_body = {ddphi - ddpsi * sth - dpsi * dth * cth,
                  ddth * cphi - dth * dphi * sphi + ddpsi * cth * sphi - dpsi * dth * sth * sphi +
                      dpsi * dphi * cth * cphi,
                  -ddth * sphi - dth * dphi * cphi + ddpsi * cth * cphi - dpsi * dth * sth * cphi -
                      dpsi * dphi * cth * sphi};
  return s;
}

Trajectory SmoothTrajectory::sample(const std::vector<TimeNs>& times_ns, TimeNs start_ns,
                                    const SE3& T_body_sensor) const {
  Trajectory out;
  out.reserve(times_ns.size());
  for (const TimeNs t : times_ns) {
    out.push_back({t, T_world_body(ns_to_s(t - start_ns)) * T_body_sensor});
  }
  return out;
}

SE3 forward_camera_mount() {
  Eigen::Matrix3d R_body_cam;
  // Columns: camera x (right) = -body y, camera y (down) = -body z, camera z = body x.
  R_body_cam << 0, 0, 1,  //
      -1, 0, 0,           //
      0, -1, 0;
  return SE3(SO3::from_matrix(R_body_cam), Eigen::Vector3d::Zero());
}

}  // namespace kestrel::sim
