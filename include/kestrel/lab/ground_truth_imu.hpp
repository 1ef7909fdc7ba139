// An IMU synthesised from a ground-truth trajectory: the control experiment of the EuRoC
// fusion targets. The real IMU of a flying MAV errs in ways its sensor YAML does not model
// (vibration, scale factors, a bias that wanders faster than its random walk); feeding the
// filter an IMU that is exactly what the YAML describes, on the same trajectory, with the same
// odometry noise, separates the filter's own error from the real IMU's (docs/fusion.md).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "kestrel/lab/fusion_experiments.hpp"

namespace kestrel::lab {

/// The trajectory through the ground-truth samples that the synthetic IMU measures: positions
/// on a natural cubic spline (per axis, through every sample), orientation rotating at a
/// constant body rate between consecutive samples (R_i exp(w_i (t - t_i)), w_i = log(R_i^T
/// R_{i+1}) / h_i). Both pass through every sample, so relative poses taken from the samples
/// are exact on it.
class GroundTruthSpline {
 public:
  /// `gt`: at least 3 samples, strictly increasing in time.
  explicit GroundTruthSpline(const std::vector<GroundTruthSample>& gt);

  [[nodiscard]] TimeNs t_begin() const { return t_.front(); }
  [[nodiscard]] TimeNs t_end() const { return t_.back(); }
  /// Position, velocity and acceleration (world) and orientation and body rate at t (clamped
  /// to [t_begin, t_end]). On an inner sample the body rate is the mean of its two intervals'.
  [[nodiscard]] Eigen::Vector3d position(TimeNs t) const;
  [[nodiscard]] Eigen::Vector3d velocity(TimeNs t) const;
  [[nodiscard]] Eigen::Vector3d acceleration(TimeNs t) const;
  [[nodiscard]] SO3 orientation(TimeNs t) const;
  [[nodiscard]] Eigen::Vector3d body_rate(TimeNs t) const;

 private:
  /// The interval [t_i, t_{i+1}] holding t, and t's offset from t_i in seconds.
  [[nodiscard]] std::size_t interval(TimeNs t, double& s) const;
  std::vector<TimeNs> t_;
  std::vector<Eigen::Vector3d> p_, m_;  // positions and the spline's second derivatives
  std::vector<SO3> r_;
  std::vector<Eigen::Vector3d> w_;  // body rate on each interval
};

struct GroundTruthImuOptions {
  /// Densities of the sensor YAML (continuous time), as the filter's fusion::FusionOptions holds
  /// them.
  fusion::ImuNoiseDensities noise;
  double gravity_m_s2 = 9.81;
  /// On: biases at the first sample the ground truth's where it has them, else zero, then their
  /// random walks, and white noise, with the densities above. Off: an ideal IMU.
  bool noise_on = true;
};

/// IMU samples at `stamps` (those inside the ground truth's span; others are dropped):
/// gyro = w_body + b_g + n_g, accel = R^T (a - g) + b_a + n_a, white noise of density/sqrt(dt)
/// per sample. `gt` is updated in place so that it describes the synthetic IMU's truth: its
/// velocities become the spline's, and its biases the synthetic ones (has_bias = true).
std::vector<io::ImuSample> imu_from_ground_truth(std::vector<GroundTruthSample>& gt,
                                                 const std::vector<TimeNs>& stamps,
                                                 const GroundTruthImuOptions& options,
                                                 std::mt19937_64& rng);

}  // namespace kestrel::lab
