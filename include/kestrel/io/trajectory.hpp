// A trajectory: time-stamped poses T_world_body, sorted by time. Trajectories are small
// (thousands of poses) and are held in memory whole, unlike image sequences.
#pragma once

#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel {

struct StampedPose {
  TimeNs t_ns = 0;
  SE3 T_world_body;  ///< maps body (camera, IMU, ...) points into the world frame
};

using Trajectory = std::vector<StampedPose>;

}  // namespace kestrel
