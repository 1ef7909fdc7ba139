// An online scale on the odometry's measurement covariance, from the normalised innovation
// squared (NIS) of the recent updates: covariance matching (Mehra 1972; Mohamed & Schwarz 1999)
// with a Sage-Husa-type forgetting, reduced to one scalar and bounded.
//
// The tracker's covariance (H^-1 of its Gauss-Newton, times a fixed covariance_scale) counts
// every pixel as independent noise: over-confident exactly where the images are weakest (the
// corridor's walls, docs/flight.md). If the odometry's true error is k times its reported
// covariance R and the filter's prediction is consistent, E[r r^T] = H P H^T + k R, and the NIS
// of an update made with lambda R, r^T (H P H^T + lambda R)^-1 r, has the mean dof exactly when
// lambda = k. So lambda * NIS / dof is one update's evidence for k (it is k when H P H^T is
// negligible, and the iteration's fixed point is k in any case), and the scale is its
// exponentially weighted mean over about `window_updates` updates.
//
// Gated updates count: their NIS is the evidence that R is too small. Each sample's NIS is
// capped at the gate (winsorised): an odometry jump, which the gate is there for, moves the scale
// by at most (cap / dof - 1) / window_updates of itself, and a consistent stream loses only the
// 0.1 % of its tail (E[min(chi2_6, 22.46)] = 5.98). Bounds: never below min_scale (1: the
// configured covariance is a floor; the NIS tests the sum H P H^T + R and cannot tell a too
// large P from a too large R, so it is not taken as evidence to sharpen R), never above
// cap / dof (0.999 gate, 6 dof: 3.74), the scale at which a measurement on the gate scores a
// typical NIS: beyond it the filter would treat what the gate refuses as ordinary.
#pragma once

#include <cstddef>
#include <string>

namespace kestrel::fusion {

/// Options of the online scale (FusionOptions' `adaptive_vo_noise*` YAML keys).
struct AdaptiveNoiseOptions {
  /// Off here, on in the closed-loop flight (FlightOptions), whose odometry misreports its
  /// covariance by a factor that changes with the scene; offline, where the odometry's
  /// covariance is known, it only slows the time offset's convergence. The measurements:
  /// docs/flight.md, "An adaptive odometry covariance", and docs/fusion.md.
  bool enabled = false;
  /// The exponential mean's time constant, in updates (alpha = 1 / window_updates). 30: one
  /// second of a 30 Hz camera; the per-update NIS / dof of 6 dof has a std of 0.58, so the
  /// mean over ~30 updates is good to ~0.08 when consistent.
  double window_updates = 30.0;
  double min_scale = 1.0;
  /// 0: the NIS cap over the degrees of freedom (gate_chi2 / 6 = 3.74 at the 0.999 gate).
  double max_scale = 0.0;

  /// Throws InputError naming the field for a value out of its range.
  void validate() const;
};

/// The estimator. Not thread-safe; one per measurement stream.
class NisNoiseScale {
 public:
  /// nis_cap > 0: the winsorisation level (the filter's chi-square gate); dof >= 1.
  NisNoiseScale(const AdaptiveNoiseOptions& options, double nis_cap, int dof);

  /// The scale to multiply the next measurement's reported covariance by.
  [[nodiscard]] double scale() const { return scale_; }
  [[nodiscard]] double lower_bound() const { return lower_; }
  [[nodiscard]] double upper_bound() const { return upper_; }
  [[nodiscard]] std::size_t samples() const { return samples_; }

  /// One update's NIS, computed with the reported covariance times `scale_used` (accepted or
  /// gated). Throws std::invalid_argument for a NaN, infinite or negative NIS or a scale_used
  /// that is not finite and positive (an invalid update must not reach the estimate).
  void add(double nis, double scale_used);

  [[nodiscard]] std::string describe() const;

 private:
  double alpha_;
  double cap_;
  double dof_;
  double lower_;
  double upper_;
  double scale_;
  std::size_t samples_ = 0;
};

}  // namespace kestrel::fusion
