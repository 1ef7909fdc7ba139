// Per-axis position and Euler-angle errors after ATE alignment, and their CSV.
#include "kestrel/eval/axis_errors.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "kestrel/core/units.hpp"
#include "kestrel/eval/csv_writer.hpp"

namespace kestrel::eval {
Eigen::Vector3d roll_pitch_yaw_zyx(const Eigen::Matrix3d& R) {
  // R = Rz(y) Ry(p) Rx(r): R(2,0) = -sin p, R(2,1) = cos p sin r, R(2,2) = cos p cos r,
  // R(1,0) = cos p sin y, R(0,0) = cos p cos y.
  // atan2 rather than asin(-R(2,0)): asin loses half the digits near pitch = +-90 deg.
  const double cos_pitch = std::hypot(R(0, 0), R(1, 0));
  const double pitch = std::atan2(-R(2, 0), cos_pitch);
  if (cos_pitch < 1e-9) {
    // Gimbal lock: with roll = 0, R(0,1) = -sin y and R(1,1) = cos y.
    return {0.0, pitch, std::atan2(-R(0, 1), R(1, 1))};
  }
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

Eigen::Matrix3d rotation_from_roll_pitch_yaw_zyx(const Eigen::Vector3d& rpy_rad) {
  return (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

double wrap_angle(double angle_rad) {
  double wrapped = std::remainder(angle_rad, 2.0 * kPi);  // in [-pi, pi]
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

Eigen::Vector3d AxisErrorSample::rpy_error_rad() const {
  const Eigen::Vector3d d = rpy_est_rad - rpy_gt_rad;
  return {wrap_angle(d.x()), wrap_angle(d.y()), wrap_angle(d.z())};
}

std::vector<AxisErrorSample> compute_axis_errors(const Trajectory& gt, const Trajectory& est,
                                                 const AteResult& ate) {
  std::vector<AxisErrorSample> samples;
  samples.reserve(ate.pairs.size());
  for (const IndexPair& pair : ate.pairs) {
    const SE3& T_gtworld_gtbody = gt[pair.first].T_world_body;
    const SE3 T_gtworld_estbody = ate.T_gtworld_estworld * est[pair.second].T_world_body;
    AxisErrorSample s;
    s.t_ns = gt[pair.first].t_ns;
    s.p_gt_m = T_gtworld_gtbody.translation();
    s.p_est_m = T_gtworld_estbody.translation();
    s.rpy_gt_rad = roll_pitch_yaw_zyx(T_gtworld_gtbody.rotation_matrix());
    s.rpy_est_rad = roll_pitch_yaw_zyx(T_gtworld_estbody.rotation_matrix());
    samples.push_back(s);
  }
  return samples;
}

void write_axis_errors_csv(const std::filesystem::path& path,
                           const std::vector<AxisErrorSample>& samples, TimeNs t0_ns,
                           std::string_view command, bool force) {
  std::vector<std::string> columns = {"t_ns", "t_s"};
  for (const char* axis : {"x", "y", "z"}) {
    for (const char* what : {"_gt_m", "_est_m", "_err_m"})
      columns.push_back(axis + std::string(what));
  }
  for (const char* axis : {"roll", "pitch", "yaw"}) {
    for (const char* what : {"_gt_deg", "_est_deg", "_err_deg"}) {
      columns.push_back(axis + std::string(what));
    }
  }
  CsvWriter csv(path, columns, command, force);
  for (const AxisErrorSample& s : samples) {
    csv.add(s.t_ns).add(ns_to_s(s.t_ns - t0_ns));
    const Eigen::Vector3d p_err = s.p_error_m();
    for (int k = 0; k < 3; ++k) csv.add(s.p_gt_m[k]).add(s.p_est_m[k]).add(p_err[k]);
    const Eigen::Vector3d rpy_err = s.rpy_error_rad();
    for (int k = 0; k < 3; ++k) {
      csv.add(s.rpy_gt_rad[k] * kRadToDeg)
          .add(s.rpy_est_rad[k] * kRadToDeg)
          .add(rpy_err[k] * kRadToDeg);
    }
    csv.end_row();
  }
  csv.close();
}

}  // namespace kestrel::eval
