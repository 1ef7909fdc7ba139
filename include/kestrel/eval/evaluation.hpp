// A whole trajectory evaluation, as `kestrel evaluate` runs it: ATE, RPE and per-axis errors
// of an estimate against ground truth, a text report, and the files (CSVs, aligned
// trajectory, figures) written into an output folder.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/eval/axis_errors.hpp"
#include "kestrel/eval/trajectory_metrics.hpp"

namespace kestrel::eval {

struct Evaluation {
  EvaluationOptions options;
  std::size_t gt_poses = 0;
  std::size_t est_poses = 0;
  AteResult ate;
  RpeResult rpe;
  FrameRotationFit frame_rotation;  ///< diagnostic (fit_frame_rotation), not a benchmark figure
  std::vector<AxisErrorSample> axes;
  TimeNs t0_ns = 0;  ///< time origin of the figures and CSVs: the first associated gt stamp
};

/// Runs ATE, RPE and the per-axis errors. Throws InputError when too few poses pair up.
Evaluation evaluate(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options);

/// A few human-readable lines: counts, ATE rmse/mean/median/max, RPE rmse, the alignment.
std::string format_report(const Evaluation& evaluation);

/// "ate_rmse_m=<v> rpe_trans_m_s=<v> rpe_rot_deg_s=<v>", 6 significant digits: one line for
/// scripts to parse.
std::string format_summary_line(const Evaluation& evaluation);

/// Writes into `dir` (which the caller has claimed with io::claim_output_dir): axis_errors.csv,
/// rpe.csv, est_aligned.txt (the estimate in the gt world, TUM format) and the figures of
/// write_evaluation_figures(). Returns the paths written, in order.
std::vector<std::filesystem::path> write_evaluation_files(const std::filesystem::path& dir,
                                                          const Trajectory& gt,
                                                          const Trajectory& est,
                                                          const Evaluation& evaluation,
                                                          std::string_view command, bool force);

/// The figures, as PNG: `<axis>.png` for x, y, z, roll, pitch, yaw (gt and aligned est over
/// time above, their difference below), top_view.png (x-y, equal aspect) and rpe.png
/// (translational and rotational RPE over time). Returns the paths written.
std::vector<std::filesystem::path> write_evaluation_figures(const std::filesystem::path& dir,
                                                            const Trajectory& est,
                                                            const Evaluation& evaluation);

}  // namespace kestrel::eval
