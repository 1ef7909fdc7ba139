// Error-state EKF with stochastic cloning (thesis 4.6): IMU propagation of the nominal state
// p, q, v, b_g, b_a, a cloned pose (p_d, q_d) of the last reference frame, and relative-pose
// updates between the clone and now with the Joseph-form covariance update (eq. 4.8).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::fusion {

/// Error-state layout: [dp, dtheta, dv, db_g, db_a, dp_d, dtheta_d, dt_d, dphi], 25 entries.
/// Attitude errors are local (body frame), q = q_hat * exp(dtheta) (thesis eqs. 4.3-4.4); dt_d
/// is the error of the camera-IMU time offset (the thesis' 21 entries plus the offset of
/// OpenVINS and VINS-Fusion; Li & Mourikis, "Online temporal calibration", IJRR 2014); dphi the
/// local error of the odometry-IMU rotation q_body_odom (OpenVINS' calib_cam_extrinsics, its
/// rotation part; Li & Mourikis IJRR 2013/2014).
namespace idx {
inline constexpr int kP = 0;
inline constexpr int kTheta = 3;
inline constexpr int kV = 6;
inline constexpr int kBg = 9;
inline constexpr int kBa = 12;
inline constexpr int kPd = 15;
inline constexpr int kThetaD = 18;
inline constexpr int kTd = 21;    ///< camera-IMU time offset t_d [s]
inline constexpr int kExt = 22;   ///< odometry-IMU rotation error dphi [rad], body frame
inline constexpr int kCore = 15;  ///< entries of the current (non-cloned) state
inline constexpr int kDim = 25;
}  // namespace idx

using Vector15d = Eigen::Matrix<double, idx::kCore, 1>;
using Matrix15d = Eigen::Matrix<double, idx::kCore, idx::kCore>;
using VectorXs = Eigen::Matrix<double, idx::kDim, 1>;
using MatrixXs = Eigen::Matrix<double, idx::kDim, idx::kDim>;
using Matrix6xs = Eigen::Matrix<double, 6, idx::kDim>;

/// The nominal state (thesis eq. 4.1): body (IMU) pose in a z-up world, velocity, biases, clone.
struct NominalState {
  TimeNs t_ns = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_world_body = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
  /// Cloned pose of the reference frame (p_d, q_d) and the time it was cloned.
  Eigen::Vector3d p_clone_world = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_world_clone = Eigen::Quaterniond::Identity();
  TimeNs clone_t_ns = 0;
  /// Camera-IMU time offset: a frame stamped t (odometry clock) was taken at IMU time t + t_d
  /// (OpenVINS' convention).
  double time_offset_s = 0.0;
  /// Odometry-IMU rotation R_D: the frame the odometry's body motions are expressed in (the
  /// IMU frame as T_body_cam's rotation says it), in the IMU frame. The odometry's motion is
  /// that of the IMU conjugated by it, R_D^T T_clone_body R_D; identity when T_body_cam is
  /// exact. Its error is local, R_D = R_D_hat exp(dphi).
  Eigen::Quaterniond q_body_odom = Eigen::Quaterniond::Identity();
  /// Not states, but what the time offset moves the poses along (first order): the body rate
  /// of the last IMU step (bias removed) and, at the clone, its body-frame velocity and rate.
  /// The clone's velocity is kept in the clone's body frame, so that a yaw of the whole
  /// state leaves the predicted measurement unchanged (no spurious yaw information).
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_clone_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_clone_body = Eigen::Vector3d::Zero();

  [[nodiscard]] SE3 T_world_body() const { return SE3(q_world_body, p_world); }
  [[nodiscard]] SE3 T_world_clone() const { return SE3(q_world_clone, p_clone_world); }
  /// Adds an error-state vector: additive except the attitudes, q <- q * exp(dtheta).
  [[nodiscard]] NominalState boxplus(const VectorXs& dx) const;
  /// The error vector e with this = other.boxplus(e) (attitude errors by the log map).
  [[nodiscard]] VectorXs boxminus(const NominalState& other) const;
  [[nodiscard]] bool all_finite() const;
};

/// Noise densities of the continuous model (thesis eq. 4.5: dQ = dt * cQ).
struct ImuNoiseDensities {
  double gyro_noise = 1.6968e-4;  ///< rad/s/sqrt(Hz)  (EuRoC ADIS16448 defaults)
  double gyro_walk = 1.9393e-5;   ///< rad/s^2/sqrt(Hz)
  double accel_noise = 2.0e-3;    ///< m/s^2/sqrt(Hz)
  double accel_walk = 3.0e-3;     ///< m/s^3/sqrt(Hz)
};

/// One IMU reading held constant over a step of length dt_s (the mean of two samples).
struct ImuReading {
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

/// Outcome of one relative-pose update, with its numbers (never a bare bool).
enum class UpdateOutcome {
  kAccepted,
  kRejectedGate,     ///< Mahalanobis distance above the chi-square gate
  kRejectedInvalid,  ///< non-finite measurement or covariance, or S not positive-definite
};
std::string_view to_string(UpdateOutcome outcome);

struct UpdateResult {
  UpdateOutcome outcome = UpdateOutcome::kAccepted;
  Vector6d residual = Vector6d::Zero();  ///< [dp, dtheta] of the measured vs predicted motion
  double mahalanobis_sq = 0.0;           ///< r^T S^-1 r
  double gate = 0.0;                     ///< the chi-square threshold it was compared with
  [[nodiscard]] bool accepted() const { return outcome == UpdateOutcome::kAccepted; }
};

/// The filter proper: no buffering or time bookkeeping of inputs (see FusionEngine).
class StochasticCloningEkf {
 public:
  StochasticCloningEkf() = default;
  StochasticCloningEkf(const ImuNoiseDensities& noise, const Eigen::Vector3d& g_world)
      : noise_(noise), g_world_(g_world) {}

  /// First-estimates Jacobians (on by default; Huang, Mourikis & Roumeliotis, ISER 2008; Li &
  /// Mourikis, "High-precision, consistent EKF-based visual-inertial odometry", IJRR 2013):
  /// the transition of the first step after an update is evaluated at the estimate the update
  /// started from, and the measurement Jacobian at the clone's first estimate, so that the
  /// global translation and the yaw about gravity stay unobservable to the filter, as they are
  /// to the sensors. Evaluated at the latest estimates instead (off), each update moves that
  /// yaw direction and the filter gains yaw information that no sensor gave (docs/fusion.md).
  void set_first_estimate_jacobians(bool on) { first_estimates_ = on; }
  [[nodiscard]] bool first_estimate_jacobians() const { return first_estimates_; }
  /// The clone's pose as first estimated (the measurement Jacobian's linearisation point).
  [[nodiscard]] SE3 clone_first_estimate() const { return SE3(q_clone_first_, p_clone_first_); }

  /// Sets the state and the 15x15 covariance of the current state; the clone is set to the
  /// current pose with its covariance (thesis: "at the beginning, we fix p_d = p"). The time
  /// offset starts at state.time_offset_s with std time_offset_sigma_s, uncorrelated; 0 keeps
  /// it fixed (not estimated: its gain row stays zero). The odometry-IMU rotation likewise
  /// starts at state.q_body_odom with std extrinsic_rotation_sigma_rad per axis (0: fixed).
  void initialize(const NominalState& state, const Matrix15d& covariance,
                  double time_offset_sigma_s = 0.0, double extrinsic_rotation_sigma_rad = 0.0);

  /// Propagates over dt_s > 0 with one reading (thesis eqs. 4.2, 4.5, 4.6; the transition
  /// is the exact Jacobian of the discrete step, so it equals I + cF dt to first order).
  void propagate(const ImuReading& reading, double dt_s);

  /// Relative pose of the body from the clone to now, T_clone_body, with the covariance of
  /// a left perturbation xi = [v, w] in the clone frame (T_true = exp(xi) * T_measured, the
  /// odometry's TrackResult convention). gate_chi2 <= 0 disables gating.
  UpdateResult update(const SE3& T_clone_body_measured, const Matrix6d& covariance_left,
                      double gate_chi2);

  /// Stochastic cloning: p_d <- p, q_d <- q with their covariances (thesis, after eq. 4.8).
  void clone();

  [[nodiscard]] const NominalState& state() const { return x_; }
  [[nodiscard]] const MatrixXs& covariance() const { return P_; }
  /// For tests and tools: overwrite the nominal state (time, clone included).
  void set_state(const NominalState& x) { x_ = x; }
  void set_time(TimeNs t_ns) { x_.t_ns = t_ns; }
  [[nodiscard]] const Eigen::Vector3d& gravity() const { return g_world_; }
  [[nodiscard]] const ImuNoiseDensities& noise() const { return noise_; }

  // --- the model, exposed for the finite-difference tests ---
  /// The discrete nominal step (the clone is untouched).
  static NominalState propagate_nominal(const NominalState& x, const ImuReading& reading,
                                        double dt_s, const Eigen::Vector3d& g_world);
  /// d(error after the step)/d(error before), 15x15 over the current state.
  static Matrix15d transition(const NominalState& x, const ImuReading& reading, double dt_s);
  /// The transition with its attitude columns evaluated at a first estimate `fe` of the state
  /// the step started from (x itself gives transition()): it maps the unobservable directions
  /// at `fe` onto those at `next` = propagate_nominal(x), Li & Mourikis 2013 eq. 26-28 in our
  /// body-frame attitude error.
  static Matrix15d transition_first_estimates(const NominalState& x, const NominalState& fe,
                                              const NominalState& next, const ImuReading& reading,
                                              double dt_s, const Eigen::Vector3d& g_world);
  /// Discrete process noise dQ = G (dt cQ) G^T over the current state.
  static Matrix15d process_noise(const ImuNoiseDensities& noise, double dt_s);
  /// Its diagonal (dQ is diagonal: isotropic densities).
  static Vector15d process_noise_diagonal(const ImuNoiseDensities& noise, double dt_s);
  /// The covariance step in place (thesis eq. 4.6): P <- F P F^T + diag(q) on the current
  /// block, F P_xc on the cross blocks, the clone and time-offset blocks unchanged. F must
  /// have the block structure of transition() (identity but for the attitude and bias columns
  /// of p, theta, v and dt I for p over v); the product skips its zero blocks.
  static void propagate_covariance(MatrixXs& P, const Matrix15d& F, const Vector15d& q_diagonal);
  /// P H^T for a measurement Jacobian H (the update's gain and innovation covariance).
  static Eigen::Matrix<double, idx::kDim, 6> covariance_times_transpose(const MatrixXs& P,
                                                                        const Matrix6xs& H);
  /// The Joseph-form update in place (thesis eq. 4.8) P <- (I - K H) P (I - K H)^T + K R K^T, given
  /// PH^T = P H^T and S = H P H^T + R, in its expanded form
  /// P - K (PH^T)^T - PH^T K^T + (K S) K^T, algebraically equal for any gain K.
  static void joseph_update(MatrixXs& P, const Eigen::Matrix<double, idx::kDim, 6>& K,
                            const Eigen::Matrix<double, idx::kDim, 6>& PHt, const Matrix6d& S);
  /// h(x) = R_D^T T_clone_body R_D with T_clone_body = T_world_clone^-1 T_world_body (thesis
  /// eq. 4.7), both poses moved to the frames' IMU times by the time offset (first order:
  /// p + v t_d, R exp(w t_d)), R_D = q_body_odom (identity: the thesis' h).
  static SE3 predict_relative_pose(const NominalState& x);
  /// Residual [p_meas - p_pred, log(R_pred^T R_meas)] (attitude in the body frame).
  static Vector6d residual(const SE3& measured, const SE3& predicted);
  /// d(residual)/d(error state): the residual is ~ H dx + noise.
  static Matrix6xs measurement_jacobian(const NominalState& x);
  /// Covariance of a left perturbation of T (clone frame) expressed in the residual's
  /// parametrisation [additive translation, local rotation].
  static Matrix6d left_to_residual_covariance(const SE3& T, const Matrix6d& covariance_left);

 private:
  ImuNoiseDensities noise_;
  Eigen::Vector3d g_world_{0.0, 0.0, -9.81};
  NominalState x_;
  MatrixXs P_ = MatrixXs::Identity();
  bool first_estimates_ = true;
  /// The estimate before the last update, until the next propagation step uses it.
  std::optional<NominalState> before_update_;
  /// Set by initialize(): no IMU reading has given the body rate yet, so the initial clone's
  /// rate (omega_clone_body) is not known; the first propagation step sets it.
  bool clone_rate_unmeasured_ = false;
  /// The clone's pose as first estimated (the Jacobians' linearisation point).
  Eigen::Vector3d p_clone_first_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_clone_first_ = Eigen::Quaterniond::Identity();
};

/// Quantile of the chi-square distribution with `dof` degrees of freedom (probability in
/// (0, 1)), by bisection on the regularised lower incomplete gamma function.
double chi_square_quantile(double probability, double dof);

}  // namespace kestrel::fusion
