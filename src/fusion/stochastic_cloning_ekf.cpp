// Error-state EKF with stochastic cloning, thesis 4.6 (eqs. 4.1-4.8).
#include "kestrel/fusion/stochastic_cloning_ekf.hpp"

#include <Eigen/Cholesky>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "kestrel/fusion/covariance_kernels.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

Quaterniond exp_q(const Vector3d& w) { return SO3::exp(w).unit_quaternion(); }
Vector3d log_q(const Quaterniond& q) { return SO3(q).log(); }

// q * exp(dtheta), renormalised (thesis: "q_k|k needs to be normalised after this step").
Quaterniond right_perturb(const Quaterniond& q, const Vector3d& dtheta) {
  Quaterniond r = q * exp_q(dtheta);
  r.normalize();
  return r;
}

}  // namespace

std::string_view to_string(UpdateOutcome outcome) {
  switch (outcome) {
    case UpdateOutcome::kAccepted:
      return "accepted";
    case UpdateOutcome::kRejectedGate:
      return "rejected by the chi-square gate";
    case UpdateOutcome::kRejectedInvalid:
      return "rejected: invalid measurement";
  }
  return "unknown";
}

NominalState NominalState::boxplus(const VectorXs& dx) const {
  NominalState r = *this;
  r.p_world += dx.segment<3>(idx::kP);
  r.q_world_body = right_perturb(q_world_body, dx.segment<3>(idx::kTheta));
  r.v_world += dx.segment<3>(idx::kV);
  r.gyro_bias_rad_s += dx.segment<3>(idx::kBg);
  r.accel_bias_m_s2 += dx.segment<3>(idx::kBa);
  r.p_clone_world += dx.segment<3>(idx::kPd);
  r.q_world_clone = right_perturb(q_world_clone, dx.segment<3>(idx::kThetaD));
  r.time_offset_s += dx(idx::kTd);
  r.q_body_odom = right_perturb(q_body_odom, dx.segment<3>(idx::kExt));
  return r;
}

VectorXs NominalState::boxminus(const NominalState& o) const {
  VectorXs e;
  e.segment<3>(idx::kP) = p_world - o.p_world;
  e.segment<3>(idx::kTheta) = log_q(o.q_world_body.conjugate() * q_world_body);
  e.segment<3>(idx::kV) = v_world - o.v_world;
  e.segment<3>(idx::kBg) = gyro_bias_rad_s - o.gyro_bias_rad_s;
  e.segment<3>(idx::kBa) = accel_bias_m_s2 - o.accel_bias_m_s2;
  e.segment<3>(idx::kPd) = p_clone_world - o.p_clone_world;
  e.segment<3>(idx::kThetaD) = log_q(o.q_world_clone.conjugate() * q_world_clone);
  e(idx::kTd) = time_offset_s - o.time_offset_s;
  e.segment<3>(idx::kExt) = log_q(o.q_body_odom.conjugate() * q_body_odom);
  return e;
}

bool NominalState::all_finite() const {
  return p_world.allFinite() && q_world_body.coeffs().allFinite() && v_world.allFinite() &&
         gyro_bias_rad_s.allFinite() && accel_bias_m_s2.allFinite() && p_clone_world.allFinite() &&
         q_world_clone.coeffs().allFinite() && std::isfinite(time_offset_s) &&
         q_body_odom.coeffs().allFinite() && omega_body.allFinite() && v_clone_body.allFinite() &&
         omega_clone_body.allFinite();
}

void StochasticCloningEkf::initialize(const NominalState& state, const Matrix15d& covariance,
                                      double time_offset_sigma_s,
                                      double extrinsic_rotation_sigma_rad) {
  if (!state.all_finite() || !covariance.allFinite() || !std::isfinite(time_offset_sigma_s) ||
      !std::isfinite(extrinsic_rotation_sigma_rad)) {
    throw std::invalid_argument("StochasticCloningEkf::initialize: non-finite state or covariance");
  }
  x_ = state;
  x_.q_world_body.normalize();
  x_.q_body_odom.normalize();
  before_update_.reset();
  P_.setZero();
  P_.topLeftCorner<idx::kCore, idx::kCore>() = 0.5 * (covariance + covariance.transpose());
  P_(idx::kTd, idx::kTd) = time_offset_sigma_s * time_offset_sigma_s;
  P_.block<3, 3>(idx::kExt, idx::kExt) =
      Matrix3d::Identity() * extrinsic_rotation_sigma_rad * extrinsic_rotation_sigma_rad;
  clone();
  clone_rate_unmeasured_ = true;
}

NominalState StochasticCloningEkf::propagate_nominal(const NominalState& x, const ImuReading& m,
                                                     double dt, const Vector3d& g) {
  // Thesis eq. 4.2 integrated over one step with the reading held constant: the attitude by
  // the exponential map (exact for a constant rate), velocity and position by the Taylor
  // series of constant acceleration (eq. 4.6 is the first-order part of it). The reading is
  // the mean of two samples, so its specific force is rotated to the world by the step's
  // MIDPOINT attitude R exp(w dt / 2), not the start's: rotating by R alone errs by
  // (w dt / 2) x a, a systematic 0.025 m/s^2 at 1 rad/s and 200 Hz, which dominates the dead
  // reckoning of an ideal IMU (docs/fusion.md, "Over 20 noise draws", has both errors).
  NominalState r = x;
  const Vector3d w = m.gyro_rad_s - x.gyro_bias_rad_s;
  const Vector3d a = m.accel_m_s2 - x.accel_bias_m_s2;
  const Matrix3d R = x.q_world_body.toRotationMatrix();
  const Vector3d acc_world = R * (SO3::exp(0.5 * w * dt).matrix() * a) + g;
  r.p_world = x.p_world + x.v_world * dt + 0.5 * acc_world * dt * dt;
  r.v_world = x.v_world + acc_world * dt;
  r.q_world_body = right_perturb(x.q_world_body, w * dt);
  r.omega_body = w;
  return r;
}

Matrix15d StochasticCloningEkf::transition(const NominalState& x, const ImuReading& m, double dt) {
  // Exact Jacobian of propagate_nominal() in the error state; to first order in dt it is
  // dF = I + cF dt with the continuous cF of the error dynamics
  //   dp' = dv, dtheta' = -[w]x dtheta - db_g, dv' = -R [a]x dtheta - R db_a.
  // With the midpoint attitude M = exp(w dt / 2): the acceleration R M a moves by
  // -R [M a]x dtheta, -R M db_a and, through M, R M [a]x Jr(w dt / 2) db_g dt / 2.
  const Vector3d w = m.gyro_rad_s - x.gyro_bias_rad_s;
  const Vector3d a = m.accel_m_s2 - x.accel_bias_m_s2;
  const Matrix3d R = x.q_world_body.toRotationMatrix();
  const Vector3d phi = w * dt;
  const Matrix3d M = SO3::exp(0.5 * phi).matrix();
  const Matrix3d RM = R * M;
  const Matrix3d d_acc_d_theta = -R * SO3::hat(M * a);
  const Matrix3d d_acc_d_bg = 0.5 * dt * RM * SO3::hat(a) * SO3::right_jacobian(0.5 * phi);
  Matrix15d F = Matrix15d::Identity();
  F.block<3, 3>(idx::kP, idx::kTheta) = 0.5 * dt * dt * d_acc_d_theta;
  F.block<3, 3>(idx::kP, idx::kV) = Matrix3d::Identity() * dt;
  F.block<3, 3>(idx::kP, idx::kBg) = 0.5 * dt * dt * d_acc_d_bg;
  F.block<3, 3>(idx::kP, idx::kBa) = -0.5 * dt * dt * RM;
  F.block<3, 3>(idx::kTheta, idx::kTheta) = SO3::exp(phi).matrix().transpose();
  F.block<3, 3>(idx::kTheta, idx::kBg) = -SO3::right_jacobian(phi) * dt;
  F.block<3, 3>(idx::kV, idx::kTheta) = dt * d_acc_d_theta;
  F.block<3, 3>(idx::kV, idx::kBg) = dt * d_acc_d_bg;
  F.block<3, 3>(idx::kV, idx::kBa) = -dt * RM;
  return F;
}

namespace {

// The attitude columns of the transition at a first estimate fe: a yaw about gravity z moves the
// error state along N(x) = [z x p, R^T z, z x v, 0, 0] (and the clone alike), translation along
// [I, 0, 0, 0, 0], and these columns make F N(fe) = N(next) (Li & Mourikis 2013, eqs. 26-28, in
// the body-frame error):
//   F_tt = R_next^T R_fe,  F_vt = -[v_next - v_fe - g dt]x R_fe,
//   F_pt = -[p_next - p_fe - v_fe dt - g dt^2 / 2]x R_fe.
// With fe = x they are transition()'s (R a dt = v_next - v - g dt), so only the first step after
// an update, whose fe is the estimate before it, needs them.
void set_first_estimate_columns(Matrix15d& F, const NominalState& fe, const NominalState& next,
                                double dt, const Vector3d& g) {
  const Matrix3d R_fe = fe.q_world_body.toRotationMatrix();
  const Matrix3d R_next = next.q_world_body.toRotationMatrix();
  const Vector3d dv = next.v_world - fe.v_world - g * dt;
  const Vector3d dp = next.p_world - fe.p_world - fe.v_world * dt - 0.5 * g * dt * dt;
  F.block<3, 3>(idx::kTheta, idx::kTheta) = R_next.transpose() * R_fe;
  F.block<3, 3>(idx::kV, idx::kTheta) = -SO3::hat(dv) * R_fe;
  F.block<3, 3>(idx::kP, idx::kTheta) = -SO3::hat(dp) * R_fe;
}

}  // namespace

Matrix15d StochasticCloningEkf::transition_first_estimates(const NominalState& x,
                                                           const NominalState& fe,
                                                           const NominalState& next,
                                                           const ImuReading& m, double dt,
                                                           const Vector3d& g) {
  Matrix15d F = transition(x, m, dt);
  set_first_estimate_columns(F, fe, next, dt, g);
  return F;
}

Vector15d StochasticCloningEkf::process_noise_diagonal(const ImuNoiseDensities& n, double dt) {
  // dQ = dt * cQ (thesis eq. 4.5) mapped by G: dtheta <- -n_g, dv <- -R n_a (isotropic,
  // so R drops out), db_g <- n_bg, db_a <- n_ba; diagonal.
  Vector15d q = Vector15d::Zero();
  q.segment<3>(idx::kTheta).setConstant(n.gyro_noise * n.gyro_noise * dt);
  q.segment<3>(idx::kV).setConstant(n.accel_noise * n.accel_noise * dt);
  q.segment<3>(idx::kBg).setConstant(n.gyro_walk * n.gyro_walk * dt);
  q.segment<3>(idx::kBa).setConstant(n.accel_walk * n.accel_walk * dt);
  return q;
}

Matrix15d StochasticCloningEkf::process_noise(const ImuNoiseDensities& n, double dt) {
  return process_noise_diagonal(n, dt).asDiagonal();
}

void StochasticCloningEkf::propagate(const ImuReading& m, double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument("StochasticCloningEkf::propagate: dt must be positive");
  }
  if (!m.gyro_rad_s.allFinite() || !m.accel_m_s2.allFinite()) {
    throw std::invalid_argument("StochasticCloningEkf::propagate: non-finite IMU reading");
  }
  Matrix15d F = transition(x_, m, dt);
  const bool clone_at_step_start = x_.clone_t_ns == x_.t_ns;
  x_ = propagate_nominal(x_, m, dt, g_world_);
  x_.t_ns += s_to_ns(dt);
  if (clone_rate_unmeasured_) {
    // The initial clone was taken before any reading gave the rate, with whatever the initial
    // state said (usually zero). Left so, the time offset's Jacobian for every measurement
    // against it would read the full rate instead of its change between the frames, w - 0,
    // and claim information about t_d that the measurements do not carry (a 1-sigma 2.5x below
    // the oracle bound in simulation, docs/fusion.md). The first reading, which spans the
    // clone's time, gives it.
    if (clone_at_step_start) x_.omega_clone_body = x_.omega_body;
    clone_rate_unmeasured_ = false;
  }
  // First estimates: only the first step after an update differs (transition_first_estimates).
  if (first_estimates_ && before_update_) {
    set_first_estimate_columns(F, *before_update_, x_, dt, g_world_);
  }
  before_update_.reset();
  propagate_covariance(P_, F, process_noise_diagonal(noise_, dt));
}

namespace {

// Rows of the current state over N columns, row-major: each row contiguous, so that an output
// row of the products below is a sum of scaled input rows (kernels::combine_rows).
template <int N>
using CoreRows = Eigen::Matrix<double, idx::kCore, N, Eigen::RowMajor>;

// F X for a transition with the block structure of transition(): the rows of the biases are
// X's own; a row of p, theta or v takes X's rows at the columns where F can be nonzero (its
// identity, the dt I of p over v, and the attitude and bias blocks): 81 N multiply-adds where
// the dense product takes 225 N.
template <int N>
void transition_times(const Matrix15d& F, const CoreRows<N>& X, CoreRows<N>& Y) {
  std::array<const double*, 11> rows{};
  std::array<double, 11> coeffs{};
  for (int r = idx::kP; r < idx::kV + 3; ++r) {
    const int block = r - r % 3;  // kP, kTheta or kV
    int terms = 0;
    const auto add = [&](int col) {
      rows[terms] = X.row(col).data();
      coeffs[terms] = F(r, col);
      ++terms;
    };
    if (block != idx::kTheta) add(r);                  // the identity of p and v
    if (block == idx::kP) add(r - idx::kP + idx::kV);  // dt I
    for (int k = 0; k < 3; ++k) add(idx::kTheta + k);
    for (int k = 0; k < 3; ++k) add(idx::kBg + k);
    if (block != idx::kTheta) {
      for (int k = 0; k < 3; ++k) add(idx::kBa + k);
    }
    kernels::combine_rows(rows.data(), coeffs.data(), terms, Y.row(r).data(), N);
  }
  Y.template bottomRows<6>() = X.template bottomRows<6>();  // the biases' rows
}

}  // namespace

void StochasticCloningEkf::propagate_covariance(MatrixXs& P, const Matrix15d& F,
                                                const Vector15d& q_diagonal) {
  // P <- F P F^T + dQ on the current block; the clone and time-offset blocks are unchanged
  // (t_d is a constant) and the cross block becomes F P_xc (the growing correlation the thesis
  // describes after eq. 4.6). One product gives [F P_cc, F P_xc] from P's top rows, and
  // F P_cc F^T = F (F P_cc)^T (P_cc symmetric).
  constexpr int kRest = idx::kDim - idx::kCore;
  const CoreRows<idx::kDim> top = P.topRows<idx::kCore>();
  CoreRows<idx::kDim> FP;
  transition_times<idx::kDim>(F, top, FP);
  const CoreRows<idx::kCore> FPt = FP.leftCols<idx::kCore>().transpose();
  CoreRows<idx::kCore> FPFt;
  transition_times<idx::kCore>(F, FPt, FPFt);
  auto core = P.topLeftCorner<idx::kCore, idx::kCore>();
  core = 0.5 * (FPFt + FPFt.transpose());
  core.diagonal() += q_diagonal;
  P.topRightCorner<idx::kCore, kRest>() = FP.rightCols<kRest>();
  P.bottomLeftCorner<kRest, idx::kCore>() = FP.rightCols<kRest>().transpose();
}

Eigen::Matrix<double, idx::kDim, 6> StochasticCloningEkf::covariance_times_transpose(
    const MatrixXs& P, const Matrix6xs& H) {
  // Column k of P H^T combines P's columns (contiguous) by row k of H.
  std::array<const double*, idx::kDim> columns{};
  for (int c = 0; c < idx::kDim; ++c) columns[c] = P.col(c).data();
  std::array<double, idx::kDim> coeffs{};
  Eigen::Matrix<double, idx::kDim, 6> PHt;
  for (int k = 0; k < 6; ++k) {
    for (int c = 0; c < idx::kDim; ++c) coeffs[c] = H(k, c);
    kernels::combine_rows(columns.data(), coeffs.data(), idx::kDim, PHt.col(k).data(), idx::kDim);
  }
  return PHt;
}

void StochasticCloningEkf::joseph_update(MatrixXs& P, const Eigen::Matrix<double, idx::kDim, 6>& K,
                                         const Eigen::Matrix<double, idx::kDim, 6>& PHt,
                                         const Matrix6d& S) {
  // (I - K H) P (I - K H)^T + K R K^T expands, with H P = (P H^T)^T and H P H^T + R = S, to
  // P - K PHt^T - PHt K^T + K S K^T: the same matrix for any K (an error in K still enters at
  // second order only), in products of 25x6x25 and 25x6x6 instead of two of 25x25x25 (kDim = 25).
  // Row i of A = (K S - PHt) K^T - K PHt^T combines the 6 columns of K and the 6 of PHt (each
  // contiguous: column-major), 12 terms per row.
  const Eigen::Matrix<double, idx::kDim, 6> KS_PHt = K * S - PHt;
  Eigen::Matrix<double, idx::kDim, idx::kDim, Eigen::RowMajor> A;
  std::array<const double*, 12> rows{};
  for (int t = 0; t < 6; ++t) {
    rows[t] = K.col(t).data();
    rows[6 + t] = PHt.col(t).data();
  }
  std::array<double, 12> coeffs{};
  for (int i = 0; i < idx::kDim; ++i) {
    for (int t = 0; t < 6; ++t) {
      coeffs[t] = KS_PHt(i, t);
      coeffs[6 + t] = -K(i, t);
    }
    kernels::combine_rows(rows.data(), coeffs.data(), 12, A.row(i).data(), idx::kDim);
  }
  P += 0.5 * (A + A.transpose());
}

namespace {

// The two frames' poses at their IMU times t + t_d, to first order in t_d (a frame stamped t
// was taken at IMU time t + t_d; the filter's state is at t): the body moves along its
// velocity and turns at its rate, T(t + t_d) = (p + v t_d, R exp(w t_d)). The clone's velocity
// is held in its own body frame (NominalState).
struct ShiftedFrames {
  Eigen::Matrix3d A;   // R_clone exp(w_clone t_d)
  Eigen::Matrix3d E;   // exp(w t_d)
  Eigen::Matrix3d Ed;  // exp(w_clone t_d)
  Vector3d u;          // R_clone^T (p + v t_d - p_clone)
  Vector3d p_rel;      // Ed^T (u - v_clone_body t_d)
  Eigen::Matrix3d R_rel;
};

ShiftedFrames shifted_frames(const NominalState& x) {
  const double td = x.time_offset_s;
  ShiftedFrames f;
  const Eigen::Matrix3d Rd = x.q_world_clone.toRotationMatrix();
  const Eigen::Matrix3d R = x.q_world_body.toRotationMatrix();
  f.E = SO3::exp(x.omega_body * td).matrix();
  f.Ed = SO3::exp(x.omega_clone_body * td).matrix();
  f.A = Rd * f.Ed;
  f.u = Rd.transpose() * (x.p_world + x.v_world * td - x.p_clone_world);
  f.p_rel = f.Ed.transpose() * (f.u - x.v_clone_body * td);
  f.R_rel = f.A.transpose() * R * f.E;
  return f;
}

}  // namespace

SE3 StochasticCloningEkf::predict_relative_pose(const NominalState& x) {
  const ShiftedFrames f = shifted_frames(x);
  const Matrix3d D = x.q_body_odom.toRotationMatrix();
  return SE3(SO3::from_matrix(D.transpose() * f.R_rel * D), D.transpose() * f.p_rel);
}

Vector6d StochasticCloningEkf::residual(const SE3& measured, const SE3& predicted) {
  Vector6d r;
  r.head<3>() = measured.translation() - predicted.translation();
  r.tail<3>() = (predicted.so3().inverse() * measured.so3()).log();
  return r;
}

Matrix6xs StochasticCloningEkf::measurement_jacobian(const NominalState& x) {
  // Thesis eq. 4.7 linearised with local attitude errors, on the frames moved by t_d
  // (shifted_frames; at t_d = 0, E = Ed = I and these are the thesis' Jacobians):
  //   p_rel = Ed^T (R_d^T (p + v t_d - p_d) - v_db t_d):
  //     d/dp = A^T, d/dp_d = -A^T, d/dv = A^T t_d, d/dtheta_d = Ed^T [u]x,
  //     d/dt_d = A^T v - Ed^T v_db - [w_d]x p_rel   (d Ed^T / dt_d = -[w_d]x Ed^T)
  //   R_rel = Ed^T R_d^T R E:
  //     d/dtheta = E^T, d/dtheta_d = -R_rel^T Ed^T, d/dt_d = w - R_rel^T w_d
  // The t_d column is the temporal-calibration Jacobian of Li & Mourikis (IJRR 2014) for a
  // relative pose: the rate difference between the two frames makes t_d observable.
  const ShiftedFrames f = shifted_frames(x);
  const double td = x.time_offset_s;
  Matrix6xs H = Matrix6xs::Zero();
  H.block<3, 3>(0, idx::kP) = f.A.transpose();
  H.block<3, 3>(0, idx::kV) = f.A.transpose() * td;
  H.block<3, 3>(0, idx::kPd) = -f.A.transpose();
  H.block<3, 3>(0, idx::kThetaD) = f.Ed.transpose() * SO3::hat(f.u);
  H.block<3, 1>(0, idx::kTd) = f.A.transpose() * x.v_world - f.Ed.transpose() * x.v_clone_body -
                               x.omega_clone_body.cross(f.p_rel);
  H.block<3, 3>(3, idx::kTheta) = f.E.transpose();
  H.block<3, 3>(3, idx::kThetaD) = -f.R_rel.transpose() * f.Ed.transpose();
  H.block<3, 1>(3, idx::kTd) = x.omega_body - f.R_rel.transpose() * x.omega_clone_body;
  // The odometry-IMU rotation: h = (D^T R_rel D, D^T p_rel). A perturbation of the IMU's motion
  // moves h by D^T of it (R_rel exp(e) conjugated is R_h exp(D^T e)); with D = D_hat exp(dphi),
  // D^T p_rel = p_h + [p_h]x dphi and R_h^T exp(-dphi) R_h exp(dphi) = exp((I - R_h^T) dphi).
  const Matrix3d D = x.q_body_odom.toRotationMatrix();
  const Vector3d p_h = D.transpose() * f.p_rel;
  const Matrix3d R_h = D.transpose() * f.R_rel * D;
  H.topRows<3>() = D.transpose() * H.topRows<3>();
  H.bottomRows<3>() = D.transpose() * H.bottomRows<3>();
  H.block<3, 3>(0, idx::kExt) = SO3::hat(p_h);
  H.block<3, 3>(3, idx::kExt) = Matrix3d::Identity() - R_h.transpose();
  return H;
}

Matrix6d StochasticCloningEkf::left_to_residual_covariance(const SE3& T, const Matrix6d& cov) {
  // exp(xi) T = (exp(w) R, p + v + w x p + O(xi^2)): the translation moves by v - [p]x w and
  // the rotation by R^T w in the local frame.
  Matrix6d J = Matrix6d::Zero();
  J.block<3, 3>(0, 0) = Matrix3d::Identity();
  J.block<3, 3>(0, 3) = -SO3::hat(T.translation());
  J.block<3, 3>(3, 3) = T.rotation_matrix().transpose();
  return J * cov * J.transpose();
}

UpdateResult StochasticCloningEkf::update(const SE3& measured, const Matrix6d& cov_left,
                                          double gate_chi2) {
  UpdateResult result;
  if (!measured.translation().allFinite() || !measured.unit_quaternion().coeffs().allFinite() ||
      !cov_left.allFinite()) {
    result.outcome = UpdateOutcome::kRejectedInvalid;
    return result;
  }
  const Matrix6d Rm = left_to_residual_covariance(measured, cov_left);
  const SE3 predicted = predict_relative_pose(x_);
  result.residual = residual(measured, predicted);
  // The Jacobian at the first estimates: the current state as propagated (no update has moved
  // it yet at this time) and the clone as it was first estimated.
  NominalState x_lin = x_;
  if (first_estimates_) {
    x_lin.p_clone_world = p_clone_first_;
    x_lin.q_world_clone = q_clone_first_;
  }
  const Matrix6xs H = measurement_jacobian(x_lin);
  const Eigen::Matrix<double, idx::kDim, 6> PHt = covariance_times_transpose(P_, H);
  Matrix6d S = H * PHt + Rm;
  S = 0.5 * (S + S.transpose());
  const Eigen::LLT<Matrix6d> llt(S);
  if (llt.info() != Eigen::Success) {
    result.outcome = UpdateOutcome::kRejectedInvalid;
    return result;
  }
  result.mahalanobis_sq = result.residual.dot(llt.solve(result.residual));
  result.gate = gate_chi2;
  if (gate_chi2 > 0.0 && !(result.mahalanobis_sq <= gate_chi2)) {
    result.outcome = UpdateOutcome::kRejectedGate;
    return result;
  }
  // K = P H^T S^-1 (S symmetric: K^T = S^-1 H P).
  const Eigen::Matrix<double, idx::kDim, 6> K = llt.solve(PHt.transpose()).transpose();
  const VectorXs dx = K * result.residual;
  // Joseph form, thesis eq. 4.8: P = (I - K H) P (I - K H)^T + K Sigma K^T.
  joseph_update(P_, K, PHt, S);
  if (!before_update_) before_update_ = x_;  // the first of updates without a step between
  x_ = x_.boxplus(dx);
  return result;
}

void StochasticCloningEkf::clone() {
  // The clone's first estimate is the current pose's: after an update, the estimate the update
  // started from (the point its Jacobian, and so the covariance's unobservable directions, were
  // taken at).
  const NominalState& first = before_update_ ? *before_update_ : x_;
  p_clone_first_ = first.p_world;
  q_clone_first_ = first.q_world_body;
  x_.p_clone_world = x_.p_world;
  x_.q_world_clone = x_.q_world_body;
  x_.clone_t_ns = x_.t_ns;
  x_.v_clone_body = x_.q_world_body.conjugate() * x_.v_world;
  x_.omega_clone_body = x_.omega_body;
  // The clone's rows and columns become copies of the current pose's (p, theta).
  P_.middleRows<3>(idx::kPd) = P_.middleRows<3>(idx::kP);
  P_.middleRows<3>(idx::kThetaD) = P_.middleRows<3>(idx::kTheta);
  P_.middleCols<3>(idx::kPd) = P_.middleCols<3>(idx::kP);
  P_.middleCols<3>(idx::kThetaD) = P_.middleCols<3>(idx::kTheta);
}

namespace {

// Regularised lower incomplete gamma P(a, x): series for x < a + 1, continued fraction else
// (Numerical Recipes 6.2).
double gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 100000; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * 1e-15) break;
    }
    return sum * std::exp(log_prefix);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

}  // namespace

double chi_square_quantile(double probability, double dof) {
  if (!(probability > 0.0 && probability < 1.0) || !(dof > 0.0)) {
    throw std::invalid_argument("chi_square_quantile: probability in (0, 1) and dof > 0 needed");
  }
  double lo = 0.0, hi = dof + 20.0 * std::sqrt(2.0 * dof) + 50.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (gamma_p(0.5 * dof, 0.5 * mid) < probability)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace kestrel::fusion
