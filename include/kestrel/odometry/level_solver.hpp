// One pyramid level of the direct alignment: robust inverse-compositional Gauss-Newton over a
// list of residual terms (thesis 3.6-3.10). The convergence and cost-increase rules live here
// and nowhere else.
#pragma once

#include <span>

#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"
#include "kestrel/odometry/residual_terms.hpp"

namespace kestrel::odometry {

/// The solver's rules, from DirectTrackerOptions.
struct SolverRules {
  int max_iterations = 50;
  int min_points = 100;  ///< fewer valid primary residuals: no overlap
  bool stop_on_cost_increase = true;
  double step_tolerance_px = 0.01;         ///< SolverOptions::step_tolerance_px
  double step_change_tolerance_px = 1e-4;  ///< SolverOptions::step_change_tolerance_px
  bool estimate_gain_bias = true;          ///< 8 parameters (pose, gain, bias), else the pose alone
  /// The level's focal length (px) and median depth (m): they turn a step into pixels.
  double focal_px = 500.0;
  double median_depth_m = 1.0;

  static SolverRules for_level(const DirectTrackerOptions& o, int level, const ReferenceLevel& L);
  [[nodiscard]] int params() const { return estimate_gain_bias ? 8 : 6; }
  /// How far a step d = [v, w, ...] moves the points, in pixels of the level: f |w| + f |v| / z
  /// at the median depth z (the gain and bias move none).
  [[nodiscard]] double step_px(const Vector8d& d) const;
};

enum class LevelEnd {
  kConverged,       ///< the step (or its change) fell below tolerance, or the cost rose
  kIterationsUsed,  ///< max iterations, or a step left the image and was undone
  kFailed,          ///< no overlap or singular normal equations: the result says which
};

/// The primary term's figures and the normal equations at the last accepted step.
struct LevelStats {
  double sigma = 0.0;
  int inliers = 0;
  int inside = 0;
  Matrix8d H = Matrix8d::Zero();
};

/// Gauss-Newton on one level. terms[0] is the primary term (photometric): its valid count is
/// the overlap and its figures the level's health. A step that raises the robust cost is halved
/// (up to 3 times: far from the optimum Gauss-Newton overshoots); if it still does, the level
/// ends at the previous estimate (the noise floor is reached).
class LevelSolver {
 public:
  /// `scratch`: room for the level's points (the robust scales' median selection).
  LevelSolver(std::span<ResidualTerm* const> terms, const SolverRules& rules, int level, int points,
              float* scratch, Estimate& estimate, TrackResult& result)
      : terms_(terms),
        rules_(rules),
        level_(level),
        points_(points),
        scratch_(scratch),
        est_(estimate),
        res_(result),
        prev_(estimate) {}

  LevelEnd run();
  [[nodiscard]] const LevelStats& stats() const { return stats_; }

 private:
  enum class StepCheck { kAccepted, kHalved, kRejected };

  void evaluate();
  LevelEnd fail_no_overlap();
  void restore_previous();
  StepCheck check_step();
  double weigh();
  bool solve_and_step(double cost);
  bool step_converged();
  void apply_step(const Vector8d& d);

  std::span<ResidualTerm* const> terms_;
  const SolverRules rules_;
  const int level_, points_;
  float* scratch_;
  Estimate& est_;
  TrackResult& res_;

  Estimate prev_;  // the estimate before the last step
  Vector8d last_step_ = Vector8d::Zero();
  LevelStats stats_;
  double prev_cost_ = 0.0;
  double prev_step_norm_ = -1.0;
  int inside_ = 0, halvings_ = 0;
};

}  // namespace kestrel::odometry
