// Robust inverse-compositional Gauss-Newton on one pyramid level (level_solver.hpp).
#include "kestrel/odometry/level_solver.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <string>

namespace kestrel::odometry {

SolverRules SolverRules::for_level(const DirectTrackerOptions& o, int level,
                                   const ReferenceLevel& L) {
  SolverRules r;
  r.max_iterations = level == 0 ? o.solver.max_iterations_finest : o.solver.max_iterations_coarse;
  r.min_points = o.health.min_points;
  r.stop_on_cost_increase = o.solver.stop_on_cost_increase;
  r.step_tolerance_px = o.solver.step_tolerance_px;
  r.step_change_tolerance_px = o.solver.step_change_tolerance_px;
  r.estimate_gain_bias = o.terms.gain_bias;
  r.focal_px = 0.5 * static_cast<double>(L.fx + L.fy);
  // A level without depth (disparity input before its first frame) counts a metre.
  r.median_depth_m = L.median_depth > 0.0 ? L.median_depth : 1.0;
  return r;
}

double SolverRules::step_px(const Vector8d& d) const {
  return focal_px * (d.segment<3>(3).norm() + d.head<3>().norm() / median_depth_m);
}

LevelEnd LevelSolver::run() {
  for (int it = 0; it < rules_.max_iterations; ++it) {
    evaluate();
    if (inside_ < rules_.min_points) {
      if (it == 0) return fail_no_overlap();
      restore_previous();  // the last step left the image: undo it and stop this level
      return LevelEnd::kIterationsUsed;
    }
    if (it > 0 && rules_.stop_on_cost_increase) {
      const StepCheck check = check_step();
      if (check == StepCheck::kHalved) continue;
      if (check == StepCheck::kRejected) {
        restore_previous();
        return LevelEnd::kConverged;
      }
    }
    halvings_ = 0;
    // Robust scales (thesis eq. 3.40), each frozen once it settles (thesis 3.10).
    for (ResidualTerm* t : terms_) t->update_scale(it, scratch_);
    const double cost = weigh();
    if (!solve_and_step(cost)) return LevelEnd::kFailed;
    if (step_converged()) return LevelEnd::kConverged;
  }
  return LevelEnd::kIterationsUsed;
}

void LevelSolver::evaluate() {
  for (ResidualTerm* t : terms_) t->evaluate(est_);
  inside_ = terms_.front()->valid();
  ++res_.iterations;
}

LevelEnd LevelSolver::fail_no_overlap() {
  res_.failure = TrackFailure::kNoOverlap;
  res_.failure_detail = std::to_string(inside_) + " of " + std::to_string(points_) +
                        " reference points land in the image on level " + std::to_string(level_);
  res_.overlap = static_cast<double>(inside_) / points_;
  return LevelEnd::kFailed;
}

// Back to the estimate before the last step; `stats_` still describe it (they are updated only
// after a step is accepted).
void LevelSolver::restore_previous() {
  est_ = prev_;
  inside_ = stats_.inside;
}

// The robust cost at the scales the step was computed with.
LevelSolver::StepCheck LevelSolver::check_step() {
  double cost = 0.0;
  for (const ResidualTerm* t : terms_) cost += t->cost();
  if (!(cost > prev_cost_)) return StepCheck::kAccepted;  // a NaN cost is not a rise
  if (halvings_ < 3 && rules_.step_px(last_step_) > 10.0 * rules_.step_tolerance_px) {
    ++halvings_;
    last_step_ *= 0.5;
    apply_step(last_step_);
    return StepCheck::kHalved;
  }
  return StepCheck::kRejected;
}

double LevelSolver::weigh() {
  double cost = 0.0;
  for (ResidualTerm* t : terms_) cost += t->weigh();
  return cost;
}

// Solves the normal equations and takes the step; false (the result says why) when they are
// singular.
bool LevelSolver::solve_and_step(double cost) {
  Matrix8d H = Matrix8d::Zero();
  Vector8d g = Vector8d::Zero();
  for (const ResidualTerm* t : terms_) t->accumulate(H, g);
  const ResidualTerm& primary = *terms_.front();
  stats_.sigma = primary.sigma();
  stats_.inliers = primary.inliers();
  stats_.inside = inside_;
  stats_.H = H;

  Vector8d delta = Vector8d::Zero();
  if (rules_.estimate_gain_bias) {
    delta = H.ldlt().solve(g);
  } else {
    delta.head<6>() = H.topLeftCorner<6, 6>().ldlt().solve(g.head<6>());
  }
  if (!delta.allFinite() || (rules_.estimate_gain_bias && std::fabs(1.0 + delta(6)) < 1e-3)) {
    res_.failure = TrackFailure::kNumerical;
    res_.failure_detail = "singular normal equations on level " + std::to_string(level_);
    return false;
  }
  prev_cost_ = cost;
  prev_ = est_;
  last_step_ = delta;
  apply_step(delta);
  return true;
}

// Converged when the step is tiny or no longer changes (it oscillates at the noise floor).
bool LevelSolver::step_converged() {
  const double step = rules_.step_px(last_step_);
  if (step < rules_.step_tolerance_px ||
      (prev_step_norm_ >= 0.0 &&
       std::fabs(step - prev_step_norm_) < rules_.step_change_tolerance_px)) {
    return true;
  }
  prev_step_norm_ = step;
  return false;
}

// Inverse-compositional update of `prev_` by d (warp_jacobian.hpp).
void LevelSolver::apply_step(const Vector8d& d) {
  est_.T_cur_ref = prev_.T_cur_ref * SE3::exp(-d.head<6>());
  est_.alpha = prev_.alpha;
  est_.beta = prev_.beta;
  if (rules_.estimate_gain_bias) {
    const double eta = 1.0 + d(6);
    est_.alpha = prev_.alpha / eta;
    est_.beta = (prev_.beta - d(7)) / eta;
  }
}

}  // namespace kestrel::odometry
