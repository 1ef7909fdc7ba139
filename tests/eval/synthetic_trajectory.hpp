// Smooth synthetic trajectories with exactly known poses, for the evaluation tests.
#pragma once

#include <cmath>
#include <functional>

#include "kestrel/io/trajectory.hpp"

namespace kestrel::test {

/// Pose at time t [s] of a hand-held-camera-like motion: a Lissajous path in a 2 m box and
/// a rotation swinging about all three axes.
inline SE3 wobbly_pose(double t) {
  const Eigen::Vector3d p(std::sin(0.7 * t), 0.5 * std::sin(1.3 * t + 0.4),
                          1.0 + 0.3 * std::cos(0.5 * t));
  const Eigen::Vector3d w(0.4 * std::sin(0.9 * t), 0.3 * std::cos(0.6 * t),
                          0.8 * std::sin(0.3 * t));
  return {SO3::exp(w), p};
}

/// `count` poses every `period_ns` from `t0_ns`, pose_at(seconds since t0).
inline Trajectory sample_trajectory(std::size_t count, TimeNs t0_ns, TimeNs period_ns,
                                    const std::function<SE3(double)>& pose_at = wobbly_pose) {
  Trajectory trajectory;
  for (std::size_t k = 0; k < count; ++k) {
    const TimeNs t_ns = t0_ns + static_cast<TimeNs>(k) * period_ns;
    trajectory.push_back({t_ns, pose_at(ns_to_s(t_ns - t0_ns))});
  }
  return trajectory;
}

}  // namespace kestrel::test
