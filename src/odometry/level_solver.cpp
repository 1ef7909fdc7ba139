// Robust inverse-compositional Gauss-Newton on one pyramid level (level_solver.hpp).
#include "kestrel/odometry/level_solver.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <string>

namespace kestrel::odometry {

SolverRules SolverRules::for_level(const DirectTrackerOptions& o, int level) {
  return {level == 0 ? o.solver.max_iterations_finest : o.solver.max_iterations_coarse,
          o.health.min_points,
          o.solver.stop_on_cost_increase,
          o.solver.update_norm_tolerance,
          o.solver.update_change_tolerance,
          o.terms.gain_bias};
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
  if (halvings_ < 3 &&
      last_step_.head(rules_.params()).norm() > 10.0 * rules_.update_norm_tolerance) {
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
  const double step = last_step_.head(rules_.params()).norm();
  if (step < rules_.update_norm_tolerance ||
      (prev_step_norm_ >= 0.0 &&
       std::fabs(step - prev_step_norm_) < rules_.update_change_tolerance)) {
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
