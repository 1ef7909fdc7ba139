// The residual terms of the direct alignment (thesis 3.5-3.10), each a small type with its warp,
// Jacobian and robust scale, behind one interface the level solver (level_solver.hpp) iterates
// over: the photometric term with gain and bias (RGB-D or disparity-space points alike: the
// reference builder already put the points and their Jacobians in the right space) and the
// point-to-plane geometric term. A new kind of residual is a new ResidualTerm.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"

namespace kestrel::odometry {

/// The estimate of an alignment: the pose and the gain/bias illumination model (thesis 3.9).
struct Estimate {
  SE3 T_cur_ref;
  double alpha = 1.0, beta = 0.0;
};

/// One term's per-iteration arrays, sized to the largest level and padded to kernels::kLanes;
/// kept by the tracker and reused (no allocation once warm).
struct TermBuffers {
  std::vector<float> residual, weight;
  std::vector<std::uint8_t> valid;
  /// Jacobian columns of a term whose Jacobian depends on the estimate (point-to-plane).
  std::array<std::vector<float>, 6> jac;

  /// Grows the arrays to `n` entries (never shrinks).
  void reserve(std::size_t n);
  /// Grows the Jacobian columns to `n` entries (never shrinks).
  void reserve_jacobian(std::size_t n);
  /// Zero residuals and weights past the last point: the SIMD kernels read whole vectors.
  void pad(int count);
};

/// How a term's robust scale is estimated (thesis eq. 3.40): from the median |r| of its valid
/// residuals over `params` parameters, not below `floor`, frozen once an update changes it by
/// less than freeze_abs + freeze_rel * sigma (thesis 3.10).
struct ScaleRule {
  int params = 6;
  double floor = 0.0;
  double freeze_abs = 0.0;
  double freeze_rel = 0.0;
};

/// One residual term of a level's robust Gauss-Newton. Weights carry 1/sigma^2, so that terms
/// combine as normalised residuals (each divided by its own robust scale: no hand-set relative
/// weight) and H^-1 is the covariance.
class ResidualTerm {
 public:
  ResidualTerm(TermBuffers& buffers, int count, float tukey_c, const ScaleRule& rule)
      : b_(buffers), count_(count), c_(tukey_c), rule_(rule) {}
  virtual ~ResidualTerm() = default;
  ResidualTerm(const ResidualTerm&) = delete;
  ResidualTerm& operator=(const ResidualTerm&) = delete;

  /// Residuals (and the Jacobian, where it depends on the estimate) at `e`; returns how many
  /// residuals are valid.
  virtual int evaluate(const Estimate& e) = 0;
  /// The robust (Tukey) cost at the current scale: what a step is accepted on.
  [[nodiscard]] virtual double cost() const = 0;
  /// Tukey weights times 1/sigma^2 (thesis eq. 3.39); returns the robust cost.
  virtual double weigh() = 0;
  /// Adds the term's J^T W J and J^T W r.
  virtual void accumulate(Matrix8d& H, Vector8d& g) const = 0;

  /// Re-estimates the robust scale unless it is frozen (never on the level's first iteration,
  /// 0). `scratch` has room for the level's points.
  void update_scale(int iteration, float* scratch);

  /// Where the next median |r| is looked for first: the median of an earlier alignment of the
  /// same level (a narrow bracket around it replaces a selection over all residuals). Speed
  /// only: the median is exact wherever it lies. 0 (the start) looks at all residuals.
  void set_median_hint(float median) { median_hint_ = median; }
  /// The last scale update's median |r| (0 before the first).
  [[nodiscard]] float median_hint() const { return median_hint_; }

  [[nodiscard]] double sigma() const { return sigma_; }
  [[nodiscard]] int valid() const { return valid_; }      ///< at the last evaluation
  [[nodiscard]] int inliers() const { return inliers_; }  ///< at the last weighing

 protected:
  TermBuffers& b_;
  const int count_;  ///< the level's points
  const float c_;    ///< Tukey cut-off, in units of sigma
  const ScaleRule rule_;
  double sigma_ = 0.0;
  int valid_ = 0, inliers_ = 0;

 private:
  bool frozen_ = false;
  float median_hint_ = 0.0F;  ///< last update's median |r|: where to look for the next one
};

/// The photometric residual with a global gain and bias (thesis 3.7, 3.9; the model and its
/// Jacobian, derived anew for the garbled eq. 3.35, in warp_jacobian.hpp):
/// r_i = alpha I_cur(pi(T_cur_ref P_i)) + beta - I_ref,i. Its inverse-compositional Jacobian is
/// the reference level's, computed once per keyframe. Points that leave the image are invalid
/// and cost the Tukey maximum.
class PhotometricTerm final : public ResidualTerm {
 public:
  PhotometricTerm(const ReferenceLevel& L, const cv::Mat& current, kernels::Sampling sampling,
                  TermBuffers& buffers, float tukey_c, const ScaleRule& rule);
  int evaluate(const Estimate& e) override;
  [[nodiscard]] double cost() const override;
  double weigh() override;
  void accumulate(Matrix8d& H, Vector8d& g) const override;

 private:
  const ReferenceLevel& L_;
  const cv::Mat& cur_;
  const kernels::Sampling sampling_;
};

/// The point-to-plane residual (Kerl et al., IROS 2013; warp_jacobian.hpp):
/// r_g,i = n_i . R^T (Q_i - t) - n_i . P_i with Q_i the current depth back-projected where P_i
/// lands, J_g,i = -[n_i, (R^T (Q_i - t)) x n_i]. Only points with a normal take part; those
/// whose sample is missing cost the Tukey maximum.
class PointToPlaneTerm final : public ResidualTerm {
 public:
  /// `depth`: the current depth level (m).
  PointToPlaneTerm(const ReferenceLevel& L, const cv::Mat& depth, float max_relative_spread,
                   TermBuffers& buffers, float tukey_c, const ScaleRule& rule);
  int evaluate(const Estimate& e) override;
  [[nodiscard]] double cost() const override;
  double weigh() override;
  void accumulate(Matrix8d& H, Vector8d& g) const override;
  /// The level's points with a normal: those the term can use.
  [[nodiscard]] int points_with_normal() const { return L_.normal_count; }

 private:
  /// What the cost kernel counts for the points without a normal (the Tukey maximum each).
  [[nodiscard]] double cost_without_normals() const;

  const ReferenceLevel& L_;
  const cv::Mat& depth_;
  const float max_spread_;
};

}  // namespace kestrel::odometry
