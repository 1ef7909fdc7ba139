// ATE and RPE as computed by the TUM RGB-D benchmark scripts (evaluate_ate.py,
// evaluate_rpe.py by J. Sturm, 2013), with exact integer time stamps.
#include "kestrel/eval/trajectory_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/eval/alignment.hpp"
#include "kestrel/eval/csv_writer.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::eval {
namespace {

/// numpy.median: the middle value, or the mean of the two middle values.
double median_of(std::vector<double> values) {
  const std::size_t n = values.size();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(values.begin(), mid, values.end());
  const double upper = *mid;
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), mid);
  return 0.5 * (lower + upper);
}

std::string span_text(const Trajectory& trajectory) {
  if (trajectory.empty()) return "has no poses";
  return "spans " + io::format_seconds(trajectory.front().t_ns) + " s to " +
         io::format_seconds(trajectory.back().t_ns) + " s (" + std::to_string(trajectory.size()) +
         " poses)";
}

std::string spans_text(const Trajectory& gt, const Trajectory& est) {
  return "ground truth " + span_text(gt) + ", estimate " + span_text(est);
}

}  // namespace

void EvaluationOptions::validate() const {
  // Bounded so that the nanosecond forms (s_to_ns) stay far inside int64: 1e10 s was 1e19 ns,
  // a signed overflow in the association.
  constexpr double kMaxSeconds = 1e6;
  if (!std::isfinite(max_diff_s) || max_diff_s <= 0.0 || max_diff_s > kMaxSeconds) {
    throw InputError("max_diff_s must be a number of seconds in (0, 1000000], got " +
                     io::format_double(max_diff_s));
  }
  if (!std::isfinite(rpe_delta_s) || rpe_delta_s <= 0.0 || rpe_delta_s > kMaxSeconds) {
    throw InputError("rpe_delta_s must be a number of seconds in (0, 1000000], got " +
                     io::format_double(rpe_delta_s));
  }
}

std::string EvaluationOptions::describe() const {
  return "max_diff_s=" + io::format_double(max_diff_s) +
         " rpe_delta_s=" + io::format_double(rpe_delta_s);
}

ErrorStats error_stats(const std::vector<double>& errors) {
  if (errors.empty()) throw std::invalid_argument("error_stats: no errors");
  ErrorStats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0.0, sum_sq = 0.0;
  s.min = errors.front();
  s.max = errors.front();
  for (const double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double dev_sq = 0.0;  // two-pass: no cancellation when the mean is large
  for (const double e : errors) dev_sq += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(dev_sq / n);
  s.median = median_of(errors);
  return s;
}

AteResult compute_ate(const Trajectory& gt, const Trajectory& est,
                      const EvaluationOptions& options) {
  options.validate();
  AteResult result;
  result.pairs = associate(stamps_of(gt), stamps_of(est), s_to_ns(options.max_diff_s));
  if (result.pairs.size() < 3) {
    throw InputError("ATE: only " + std::to_string(result.pairs.size()) +
                     " pose pairs have time stamps within " +
                     io::format_double(options.max_diff_s) +
                     " s of each other; at least 3 are needed (" + spans_text(gt, est) + ")");
  }
  std::vector<Eigen::Vector3d> p_est, p_gt;
  p_est.reserve(result.pairs.size());
  p_gt.reserve(result.pairs.size());
  for (const IndexPair& pair : result.pairs) {
    p_gt.push_back(gt[pair.first].T_world_body.translation());
    p_est.push_back(est[pair.second].T_world_body.translation());
  }
  result.T_gtworld_estworld = align_rigid(p_est, p_gt);
  result.errors_m.reserve(p_est.size());
  for (std::size_t k = 0; k < p_est.size(); ++k) {
    result.errors_m.push_back((result.T_gtworld_estworld * p_est[k] - p_gt[k]).norm());
  }
  result.stats_m = error_stats(result.errors_m);
  return result;
}

std::size_t find_closest_index(const std::vector<TimeNs>& t_ns, TimeNs t) {
  // Line by line the script's bisection, so that ties resolve as they do there.
  const auto distance = [t](TimeNs s) { return s > t ? s - t : t - s; };
  std::size_t beginning = 0;
  std::size_t end = t_ns.size();
  std::size_t best = 0;
  TimeNs difference = distance(t_ns[0]);
  while (beginning < end) {
    const std::size_t middle = (beginning + end) / 2;
    if (distance(t_ns[middle]) < difference) {
      difference = distance(t_ns[middle]);
      best = middle;
    }
    if (t_ns[middle] == t) return middle;
    if (t_ns[middle] > t) {
      end = middle;
    } else {
      beginning = middle + 1;
    }
  }
  return best;
}

double RpeResult::rot_rmse_deg_s() const { return rot_rad.rmse * kRadToDeg / delta_s; }

RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est,
                      const EvaluationOptions& options) {
  options.validate();
  if (gt.size() < 2 || est.size() < 2) {
    throw InputError("RPE: needs at least 2 poses in each trajectory (" + spans_text(gt, est) +
                     ")");
  }
  const std::vector<TimeNs> t_gt = stamps_of(gt);
  const std::vector<TimeNs> t_est = stamps_of(est);
  const TimeNs delta_ns = s_to_ns(options.rpe_delta_s);

  // A gt pose stands in for an est pose only within two median gt intervals of it.
  std::vector<double> gt_intervals_ns;
  gt_intervals_ns.reserve(t_gt.size() - 1);
  for (std::size_t k = 1; k < t_gt.size(); ++k) {
    gt_intervals_ns.push_back(static_cast<double>(t_gt[k] - t_gt[k - 1]));
  }
  const double gt_max_time_difference_ns = 2.0 * median_of(gt_intervals_ns);
  const auto too_far = [&](TimeNs a, TimeNs b) {
    return static_cast<double>(a > b ? a - b : b - a) > gt_max_time_difference_ns;
  };

  RpeResult result;
  result.delta_s = options.rpe_delta_s;
  std::vector<double> trans_m, rot_rad;
  std::size_t windows = 0;  // before the ground-truth check, for the error message
  for (std::size_t i = 0; i < t_est.size(); ++i) {
    const std::size_t j = find_closest_index(t_est, t_est[i] + delta_ns);
    // The script drops windows whose end is the last pose: near the end of the estimate the
    // closest stamp to t + delta is the last one whatever delta is, so the window is short.
    if (j == t_est.size() - 1) continue;
    ++windows;
    const std::size_t g0 = find_closest_index(t_gt, t_est[i]);
    const std::size_t g1 = find_closest_index(t_gt, t_est[j]);
    if (too_far(t_gt[g0], t_est[i]) || too_far(t_gt[g1], t_est[j])) continue;
    // evaluate_rpe.py: error44 = ominus(ominus(E_j, E_i), ominus(G_1, G_0)) with
    // ominus(a, b) = a^-1 b, i.e. error = (E_i^-1 E_j) (G_1^-1 G_0) = D_est D_gt^-1, where
    // D = the motion over the window.
    const SE3& E_i = est[i].T_world_body;
    const SE3& E_j = est[j].T_world_body;
    const SE3& G_0 = gt[g0].T_world_body;
    const SE3& G_1 = gt[g1].T_world_body;
    const SE3 error = (E_i.inverse() * E_j) * (G_1.inverse() * G_0);
    RpePair pair{i, j, g0, g1, error.translation().norm(), error.so3().angle()};
    // The script's angle is arccos((trace R - 1) / 2); SO3::angle() is the same angle from
    // the quaternion by atan2, which keeps its digits for small angles where arccos loses
    // half of them (~1e-8 rad).
    trans_m.push_back(pair.trans_m);
    rot_rad.push_back(pair.rot_rad);
    result.pairs.push_back(pair);
  }
  if (result.pairs.size() < 2) {
    throw InputError("RPE: the estimate has " + std::to_string(windows) + " windows of " +
                     io::format_double(options.rpe_delta_s) + " s, of which " +
                     std::to_string(result.pairs.size()) +
                     " have ground truth within two gt intervals at both ends; at least 2 are "
                     "needed (" +
                     spans_text(gt, est) + ")");
  }
  result.trans_m = error_stats(trans_m);
  result.rot_rad = error_stats(rot_rad);
  return result;
}

FrameRotationFit fit_frame_rotation(const Trajectory& gt, const Trajectory& est,
                                    const RpeResult& rpe) {
  // Residual of one window: log(D_est^-1 R^T D_gt R) (zero when the estimate's motion is the
  // ground truth's seen from a frame turned by R); its Jacobian in a right perturbation of R by
  // central differences (3 parameters, a few hundred windows: exactness costs nothing here).
  std::vector<std::pair<SO3, SO3>> motions;  // (D_est, D_gt) rotations
  motions.reserve(rpe.pairs.size());
  for (const RpePair& p : rpe.pairs) {
    motions.emplace_back(est[p.est0].T_world_body.so3().inverse() * est[p.est1].T_world_body.so3(),
                         gt[p.gt0].T_world_body.so3().inverse() * gt[p.gt1].T_world_body.so3());
  }
  auto residual = [](const SO3& D_est, const SO3& D_gt, const SO3& R) {
    return (D_est.inverse() * R.inverse() * D_gt * R).log();
  };
  FrameRotationFit fit;
  for (int it = 0; it < 20 && !motions.empty(); ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (const auto& [D_est, D_gt] : motions) {
      const Eigen::Vector3d r = residual(D_est, D_gt, fit.R);
      Eigen::Matrix3d J;
      for (int a = 0; a < 3; ++a) {
        Eigen::Vector3d h = Eigen::Vector3d::Zero();
        h(a) = 1e-6;
        J.col(a) = (residual(D_est, D_gt, fit.R * SO3::exp(h)) -
                    residual(D_est, D_gt, fit.R * SO3::exp(-h))) /
                   2e-6;
      }
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    const Eigen::Vector3d step = -H.ldlt().solve(g);
    if (!step.allFinite()) break;
    fit.R = fit.R * SO3::exp(step);
    if (step.norm() < 1e-10) {
      fit.converged = true;
      break;
    }
  }
  double sq = 0.0;
  for (const auto& [D_est, D_gt] : motions) sq += residual(D_est, D_gt, fit.R).squaredNorm();
  fit.rot_rmse_deg_s = motions.empty() ? 0.0
                                       : std::sqrt(sq / static_cast<double>(motions.size())) *
                                             kRadToDeg / rpe.delta_s;
  return fit;
}

void write_rpe_csv(const std::filesystem::path& path, const Trajectory& gt, const Trajectory& est,
                   const RpeResult& rpe, std::string_view command, bool force) {
  CsvWriter csv(
      path, {"t_est0_ns", "t_est1_ns", "t_gt0_ns", "t_gt1_ns", "trans_error_m", "rot_error_deg"},
      command, force);
  for (const RpePair& p : rpe.pairs) {
    csv.add(est[p.est0].t_ns).add(est[p.est1].t_ns).add(gt[p.gt0].t_ns).add(gt[p.gt1].t_ns);
    csv.add(p.trans_m).add(p.rot_rad * kRadToDeg);
    csv.end_row();
  }
  csv.close();
}

}  // namespace kestrel::eval
