// The simulator path of the fusion: a smooth flight with analytic derivatives, the IMU samples
// it produces (with the sensor YAML's white noise and random-walk biases), noisy relative
// poses of a camera on it, and Monte-Carlo NEES of the filter against the truth.
//
// The flight is a small analytic one owned here, so the fusion tests do not depend on the
// renderer; sim::SmoothTrajectory provides the same quantities once it is complete.
#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <random>
#include <vector>

#include "kestrel/fusion/fusion_engine.hpp"

namespace kestrel::lab {

/// The body's full kinematic state at one instant.
struct FlightPoint {
  SE3 T_world_body;
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();  ///< rad/s in the body frame
};

/// p(t) and roll/pitch/yaw(t) as sums of sinusoids with random amplitudes, frequencies and
/// phases (seeded); R = Rz(yaw) Ry(pitch) Rx(roll). A flight of a few metres at ~1 m/s with
/// +-20 deg roll/pitch and a turning yaw, like a MAV in a motion-capture room. seed 0 is
/// a body at rest, level, at the origin.
class SimulatedFlight {
 public:
  explicit SimulatedFlight(std::uint64_t seed);
  [[nodiscard]] FlightPoint at(double t_s) const;

 private:
  struct Term {
    double amplitude, omega, phase;
  };
  std::array<std::vector<Term>, 6> terms_;  // x, y, z, roll, pitch, yaw
  std::array<double, 6> offset_{};
  double yaw_rate_ = 0.0;
};

/// gyro = omega_body, accel = R^T (a - g): an ideal IMU on the body.
io::ImuSample ideal_imu_sample(const FlightPoint& point, TimeNs t_ns,
                               const Eigen::Vector3d& g_world);

/// The sensor model of fusion::FusionOptions::noise applied to one ideal sample taken dt after the
/// previous one: with `walk` the biases first walk by density * sqrt(dt); then the sample gets
/// the biases plus white noise of density / sqrt(dt). Draws, in order: gyro walk, accel walk (if
/// walk), gyro noise, accel noise.
void add_imu_errors(io::ImuSample& sample, Eigen::Vector3d& gyro_bias, Eigen::Vector3d& accel_bias,
                    const fusion::ImuNoiseDensities& noise, double dt, bool walk,
                    std::mt19937_64& rng);

struct SimulationOptions {
  double duration_s = 30.0;
  double imu_rate_hz = 200.0;
  double vo_rate_hz = 20.0;
  double vo_sigma_p_m = 0.01;     ///< per relative pose, per axis
  double vo_sigma_rot_deg = 0.5;  ///< per relative pose, per axis
  bool imu_noise = true;          ///< white noise and bias random walk as in fusion::FusionOptions
  /// Off: each relative pose from the previous frame. On: from a keyframe, switched as in
  /// `kestrel lab fuse-eval` (EurocExperimentOptions) when the true motion from it exceeds
  /// 5 deg or 0.15 m, or after 20 frames; the same noise per measurement.
  bool vo_keyframes = false;
  double vo_keyframe_max_rot_deg = 5.0;
  double vo_keyframe_max_trans_m = 0.15;
  int vo_keyframe_max_frames = 20;
  /// Camera in the body: EuRoC V1_01 cam0 T_BS, rounded (exercises the extrinsics path).
  SE3 T_body_cam =
      SE3(SO3::from_matrix((Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished()),
          Eigen::Vector3d(-0.02, -0.06, 0.01));
};

/// One simulated run: IMU samples, odometry measurements and the truth.
struct SimulatedRun {
  std::vector<io::ImuSample> imu;
  std::vector<fusion::RelativePoseMeasurement> odometry;
  Eigen::Vector3d gyro_bias0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias0 = Eigen::Vector3d::Zero();
  /// True biases at every IMU sample (index-aligned with imu).
  std::vector<Eigen::Vector3d> gyro_bias, accel_bias;
};

/// The true nominal state (biases from the run) at time t_ns.
fusion::NominalState true_state(const SimulatedFlight& flight, const SimulatedRun& run, TimeNs t_ns,
                                double imu_rate_hz);

/// Draws a run: initial biases from the prior of `fusion` (init_sigma_*_bias), then their
/// random walks and white noise with its densities; odometry noise xi ~ N(0, Sigma) applied
/// as T_meas = exp(-xi) T_true, so that T_true = exp(xi) T_meas as the filter assumes.
SimulatedRun simulate_run(const SimulatedFlight& flight, const SimulationOptions& sim,
                          const fusion::FusionOptions& fusion, std::mt19937_64& rng);

/// The measurement covariance the odometry reports in simulation.
Matrix6d simulated_vo_covariance(const SimulationOptions& sim);

struct NeesResult {
  int runs = 0;
  std::vector<double> t_s;
  /// Averages over the runs at each odometry time stamp (3 dof each).
  std::vector<double> nees_p, nees_theta, nees_v;
  double lower_bound = 0.0, upper_bound = 0.0;          ///< 95 % two-sided, chi2(3 runs) / runs
  double mean_p = 0.0, mean_theta = 0.0, mean_v = 0.0;  ///< time averages
  double inside_p = 0.0, inside_theta = 0.0, inside_v = 0.0;  ///< fraction of time steps inside
  double rmse_p_m = 0.0;                                      ///< over all runs and steps
};

/// Monte-Carlo NEES of the filter: each run draws the initial estimate from the prior
/// around the truth, a new flight (seed + run) and new noise. `stop`, polled between runs: once
/// it is true the result covers the runs done (NeesResult::runs; 0: none).
NeesResult monte_carlo_nees(int runs, const SimulationOptions& sim,
                            const fusion::FusionOptions& fusion, std::uint64_t seed,
                            const std::atomic<bool>* stop = nullptr);

/// The online camera-IMU time offset on a simulated flight: the odometry's frames are stamped
/// t - offset_s for IMU time t (a frame stamped t was taken at IMU time t + t_d), the filter
/// starts at the true pose with zero biases and t_d = options.time_offset_s.
struct TimeOffsetRun {
  double true_offset_s = 0.0;
  double final_estimate_s = 0.0, final_sigma_s = 0.0;
  /// The first time after which |t_d estimate - offset| stays below `tolerance_s` to the end;
  /// negative if it never does.
  double converged_after_s = -1.0;
  /// The first time |t_d estimate - offset| is below `tolerance_s` (it may leave again);
  /// negative if never.
  double first_within_s = -1.0;
  double fused_rmse_m = 0.0;        ///< position, at every odometry stamp, whole flight
  double fused_rmse_after_m = 0.0;  ///< the same from `compare_after_s` on
  /// At every odometry stamp: the estimate, the filter's 1-sigma, and the oracle bound: the
  /// 1-sigma that the prior and the measurements so far allow t_d when every other quantity (pose,
  /// velocity, rates, biases) is known exactly, 1 / sqrt(1/sigma0^2 + sum_k J_k^T R^-1 J_k) with
  /// J_k = d h_k / d t_d from the true flight. No estimator of t_d from these measurements can do
  /// better on average (Cramer-Rao), so it tells the information apart from the filter.
  std::vector<double> t_s, estimate_s, sigma_s, oracle_sigma_s;
};

/// The value of `values` at the last stamp of `t_s` at or before `t`; NaN if there is none.
double value_at(const std::vector<double>& t_s, const std::vector<double>& values, double t);
TimeOffsetRun time_offset_run(const SimulationOptions& sim, const fusion::FusionOptions& fusion,
                              double offset_s, std::uint64_t seed, double tolerance_s = 1e-3,
                              double compare_after_s = 10.0);

}  // namespace kestrel::lab
