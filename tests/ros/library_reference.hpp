// The library's own result on a TUM folder, computed exactly as `kestrel odometry` does
// (io::TumRgbdSequence -> DirectTracker with default options): what the ROS paths must agree
// with. Declared C++17-clean so that both ROS test programs can use it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace kestrel::test {

struct ReferencePose {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  bool ok = false;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  ///< TrackResult's
};

/// The first `max_frames` frames (0: all) of `folder` with camera `camera` (preset or file).
std::vector<ReferencePose> library_rgbd_trajectory(const std::string& folder,
                                                   const std::string& camera,
                                                   std::size_t max_frames);

/// Largest position difference (m) and rotation angle (rad) between two poses.
inline std::pair<double, double> pose_difference(const Eigen::Vector3d& p_a,
                                                 const Eigen::Quaterniond& q_a,
                                                 const Eigen::Vector3d& p_b,
                                                 const Eigen::Quaterniond& q_b) {
  const double dp = (p_a - p_b).norm();
  const double dq = q_a.normalized().angularDistance(q_b.normalized());
  return {dp, dq};
}

}  // namespace kestrel::test
