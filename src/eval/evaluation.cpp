// Running a whole evaluation, reporting it, and writing its files.
#include "kestrel/eval/evaluation.hpp"

#include <array>
#include <cstdio>

#include "kestrel/core/units.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::eval {
namespace {}  // namespace

Evaluation evaluate(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options) {
  Evaluation e;
  e.options = options;
  e.gt_poses = gt.size();
  e.est_poses = est.size();
  e.ate = compute_ate(gt, est, options);
  e.rpe = compute_rpe(gt, est, options);
  e.frame_rotation = fit_frame_rotation(gt, est, e.rpe);
  e.axes = compute_axis_errors(gt, est, e.ate);
  e.t0_ns = gt[e.ate.pairs.front().first].t_ns;
  return e;
}

std::string format_report(const Evaluation& e) {
  const ErrorStats& ate = e.ate.stats_m;
  const ErrorStats& trans = e.rpe.trans_m;
  const ErrorStats& rot = e.rpe.rot_rad;
  const SE3& T = e.ate.T_gtworld_estworld;
  const Eigen::Vector3d& t = T.translation();
  // snprintf with literal patterns, so that -Wformat checks every argument.
  std::array<char, 256> line{};
  std::string out;
  std::snprintf(line.data(), line.size(), "poses: %zu ground truth, %zu estimated\n", e.gt_poses,
                e.est_poses);
  out += line.data();
  std::snprintf(line.data(), line.size(), "associated pairs: %zu (stamps within %g s)\n",
                e.ate.pairs.size(), e.options.max_diff_s);
  out += line.data();
  std::snprintf(line.data(), line.size(),
                "alignment gt<-est: rotation %.4f deg, translation (%.4f, %.4f, %.4f) m\n",
                T.so3().angle() * kRadToDeg, t.x(), t.y(), t.z());
  out += line.data();
  std::snprintf(line.data(), line.size(), "ATE [m]: rmse %.6f  mean %.6f  median %.6f  max %.6f\n",
                ate.rmse, ate.mean, ate.median, ate.max);
  out += line.data();
  std::snprintf(line.data(), line.size(), "RPE over %g s windows: %zu pairs\n", e.rpe.delta_s,
                e.rpe.pairs.size());
  out += line.data();
  std::snprintf(line.data(), line.size(),
                "  translational [m]: rmse %.6f  mean %.6f  median %.6f  max %.6f\n", trans.rmse,
                trans.mean, trans.median, trans.max);
  out += line.data();
  std::snprintf(line.data(), line.size(),
                "  rotational [deg]:  rmse %.6f  mean %.6f  median %.6f  max %.6f\n",
                rot.rmse * kRadToDeg, rot.mean * kRadToDeg, rot.median * kRadToDeg,
                rot.max * kRadToDeg);
  out += line.data();
  const FrameRotationFit& f = e.frame_rotation;
  const Eigen::Vector3d w = f.R.log();
  const Eigen::Vector3d axis =
      w.norm() > 0.0 ? Eigen::Vector3d(w.normalized()) : Eigen::Vector3d::UnitZ();
  std::snprintf(
      line.data(), line.size(),
      "  (diagnostic, not a benchmark figure: a constant %.3f deg turn of the estimate's "
      "frame about (%.2f, %.2f, %.2f) explains the windows best; without it %.4f deg/s)\n",
      w.norm() * kRadToDeg, axis.x(), axis.y(), axis.z(), f.rot_rmse_deg_s);
  out += line.data();
  return out;
}

std::string format_summary_line(const Evaluation& e) {
  std::array<char, 128> line{};
  std::snprintf(line.data(), line.size(), "ate_rmse_m=%.6g rpe_trans_m_s=%.6g rpe_rot_deg_s=%.6g",
                e.ate.stats_m.rmse, e.rpe.trans_rmse_m_s(), e.rpe.rot_rmse_deg_s());
  return line.data();
}

std::vector<std::filesystem::path> write_evaluation_files(const std::filesystem::path& dir,
                                                          const Trajectory& gt,
                                                          const Trajectory& est,
                                                          const Evaluation& evaluation,
                                                          std::string_view command, bool force) {
  std::vector<std::filesystem::path> written;
  written.push_back(dir / "axis_errors.csv");
  write_axis_errors_csv(written.back(), evaluation.axes, evaluation.t0_ns, command, force);
  written.push_back(dir / "rpe.csv");
  write_rpe_csv(written.back(), gt, est, evaluation.rpe, command, force);
  Trajectory aligned = est;
  for (StampedPose& pose : aligned) {
    pose.T_world_body = evaluation.ate.T_gtworld_estworld * pose.T_world_body;
  }
  written.push_back(dir / "est_aligned.txt");
  io::write_tum_trajectory(written.back(), aligned, command, force);
  for (auto& figure : write_evaluation_figures(dir, est, evaluation)) {
    written.push_back(std::move(figure));
  }
  return written;
}

}  // namespace kestrel::eval
