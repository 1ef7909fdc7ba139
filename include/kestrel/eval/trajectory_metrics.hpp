// Absolute trajectory error (ATE) and relative pose error (RPE), reproducing the TUM RGB-D
// benchmark's evaluate_ate.py and evaluate_rpe.py (--fixed_delta, --delta_unit s).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/eval/association.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/io/trajectory.hpp"

namespace kestrel::eval {

/// Options of a trajectory evaluation; the defaults are the TUM scripts' defaults.
struct EvaluationOptions {
  /// ATE association: gt and est poses pair up when their stamps differ by less than this.
  double max_diff_s = 0.02;
  /// RPE window: each est pose is compared with the est pose closest to delta_s later.
  double rpe_delta_s = 1.0;

  /// Throws InputError unless both are positive and finite.
  void validate() const;
  /// "max_diff_s=0.02 rpe_delta_s=1", for logs.
  [[nodiscard]] std::string describe() const;
};

/// Summary of a list of errors; std is the population deviation (numpy.std), median the
/// mean of the two middle values for an even count (numpy.median).
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0, mean = 0.0, median = 0.0, std = 0.0, min = 0.0, max = 0.0;
};
/// Throws std::invalid_argument for an empty list.
ErrorStats error_stats(const std::vector<double>& errors);

struct AteResult {
  std::vector<IndexPair> pairs;  ///< (gt index, est index), sorted by gt time
  SE3 T_gtworld_estworld;        ///< rigid alignment of the estimate onto the ground truth
  std::vector<double> errors_m;  ///< |T p_est - p_gt| per pair
  ErrorStats stats_m;
};

/// evaluate_ate.py: associate gt (first) with est (second) within max_diff_s, align the est
/// positions rigidly (no scale) onto the gt positions, and measure the position errors.
/// Throws InputError when fewer than 3 pairs associate (a rigid alignment needs 3 points).
AteResult compute_ate(const Trajectory& gt, const Trajectory& est,
                      const EvaluationOptions& options);

struct RpePair {
  std::size_t est0 = 0, est1 = 0;  ///< est indices i and j, about delta apart
  std::size_t gt0 = 0, gt1 = 0;    ///< closest gt indices to them
  double trans_m = 0.0;            ///< translation of the error motion
  double rot_rad = 0.0;            ///< rotation angle of the error motion
};

struct RpeResult {
  double delta_s = 0.0;
  std::vector<RpePair> pairs;  ///< in est time order
  ErrorStats trans_m;
  ErrorStats rot_rad;
  /// Drift rates: RMSE over windows of delta_s divided by delta_s (for the default 1 s
  /// window, exactly the script's RMSE in m and deg).
  [[nodiscard]] double trans_rmse_m_s() const { return trans_m.rmse / delta_s; }
  [[nodiscard]] double rot_rmse_deg_s() const;
};

/// evaluate_rpe.py with --fixed_delta --delta_unit s. Throws InputError when fewer than 2
/// pairs remain (trajectories that do not overlap, or shorter than the window).
RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est,
                      const EvaluationOptions& options);

/// A diagnostic, not a benchmark figure: the constant rotation R between the estimate's body
/// frame and the ground truth's that best explains the rotations of the RPE windows (the
/// estimate's motion D_est against R^T D_gt R, Gauss-Newton on the sum of squared angles),
/// and the rotational RPE with it removed. A calibration offset between a sensor and the frame
/// the ground truth gives it shows up as the same R for different methods (docs/evaluation.md).
struct FrameRotationFit {
  SO3 R;                        ///< from the ground truth's body frame to the estimate's
  double rot_rmse_deg_s = 0.0;  ///< the rotational RPE with R removed (deg per window length)
  bool converged = false;
};
FrameRotationFit fit_frame_rotation(const Trajectory& gt, const Trajectory& est,
                                    const RpeResult& rpe);

/// evaluate_rpe.py's find_closest_index(): a bisection over sorted `t_ns` returning the index
/// of the stamp closest to t (ties: the first best found on the bisection path). `t_ns` must
/// not be empty.
std::size_t find_closest_index(const std::vector<TimeNs>& t_ns, TimeNs t);

/// CSV of the RPE pairs (t_est0_ns, t_est1_ns, t_gt0_ns, t_gt1_ns, trans_error_m,
/// rot_error_deg), the script's --save content; provenance line first.
void write_rpe_csv(const std::filesystem::path& path, const Trajectory& gt, const Trajectory& est,
                   const RpeResult& rpe, std::string_view command, bool force = false);

}  // namespace kestrel::eval
