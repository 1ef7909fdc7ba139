// Per-axis error series over time (the thesis' figures, 3.11): x, y, z and roll, pitch, yaw
// of the ground truth and of the ATE-aligned estimate, and their differences.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string_view>
#include <vector>

#include "kestrel/eval/trajectory_metrics.hpp"
#include "kestrel/io/trajectory.hpp"

namespace kestrel::eval {

/// Euler angles (roll, pitch, yaw) in rad of R = Rz(yaw) Ry(pitch) Rx(roll): the ZYX
/// (yaw-pitch-roll, aerospace) convention, intrinsic z, y', x''. Roll and yaw in (-pi, pi],
/// pitch in [-pi/2, pi/2]. At pitch = +-pi/2 (gimbal lock) only roll -+ yaw is defined; roll
/// is then 0.
Eigen::Vector3d roll_pitch_yaw_zyx(const Eigen::Matrix3d& R);
/// The rotation of roll_pitch_yaw_zyx()'s convention.
Eigen::Matrix3d rotation_from_roll_pitch_yaw_zyx(const Eigen::Vector3d& rpy_rad);
/// An angle mapped to (-pi, pi].
double wrap_angle(double angle_rad);

/// One associated pair: ground truth, and the estimate mapped into the gt world by the ATE
/// alignment, T_gtworld_body = T_gtworld_estworld * T_estworld_body.
struct AxisErrorSample {
  TimeNs t_ns = 0;  ///< the gt stamp
  Eigen::Vector3d p_gt_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_est_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_gt_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_est_rad = Eigen::Vector3d::Zero();

  /// est - gt, per axis.
  [[nodiscard]] Eigen::Vector3d p_error_m() const { return p_est_m - p_gt_m; }
  /// est - gt per angle, wrapped to (-pi, pi] (a yaw of 179 deg vs -179 deg is 2 deg off).
  [[nodiscard]] Eigen::Vector3d rpy_error_rad() const;
};

/// The samples of every ATE pair, in time order.
std::vector<AxisErrorSample> compute_axis_errors(const Trajectory& gt, const Trajectory& est,
                                                 const AteResult& ate);

/// CSV with t_ns, t_s (seconds since t0_ns) and for each of x, y, z (m) and roll, pitch, yaw
/// (deg) the columns `<axis>_gt`, `<axis>_est`, `<axis>_err`; provenance line first.
void write_axis_errors_csv(const std::filesystem::path& path,
                           const std::vector<AxisErrorSample>& samples, TimeNs t0_ns,
                           std::string_view command, bool force = false);

}  // namespace kestrel::eval
