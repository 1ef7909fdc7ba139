// SE(3) exponential, logarithm, adjoint and left Jacobian.
#include "kestrel/geometry/se3.hpp"

#include <cmath>

namespace kestrel {

SE3 SE3::from_matrix(const Eigen::Matrix4d& T) {
  return {SO3::from_matrix(T.topLeftCorner<3, 3>()), T.topRightCorner<3, 1>()};
}

SE3 SE3::exp(const Tangent& xi) {
  const Eigen::Vector3d v = xi.head<3>();
  const Eigen::Vector3d w = xi.tail<3>();
  const So3ExpAndJacobianProduct e = SO3::exp_and_left_jacobian_times(w, v);
  return {e.rotation, e.jacobian_times_v};
}

SE3::Tangent SE3::log() const {
  const Eigen::Vector3d w = so3_.log();
  Tangent xi;
  xi << SO3::left_jacobian_inverse(w) * t_, w;
  return xi;
}

SE3 SE3::inverse() const {
  const SO3 R_inv = so3_.inverse();
  return {R_inv, -(R_inv * t_)};
}

SE3 SE3::operator*(const SE3& other) const { return {so3_ * other.so3_, so3_ * other.t_ + t_}; }

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = so3_.matrix();
  T.topRightCorner<3, 1>() = t_;
  return T;
}

Eigen::Matrix<double, 3, 4> SE3::matrix3x4() const { return matrix().topRows<3>(); }

Matrix6d SE3::adjoint() const {
  const Eigen::Matrix3d R = so3_.matrix();
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.topRightCorner<3, 3>() = SO3::hat(t_) * R;
  Ad.bottomRightCorner<3, 3>() = R;
  return Ad;
}

Eigen::Matrix4d SE3::hat(const Tangent& xi) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = SO3::hat(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>();
  return X;
}

SE3::Tangent SE3::vee(const Eigen::Matrix4d& X) {
  Tangent xi;
  xi << X.topRightCorner<3, 1>(), SO3::vee(X.topLeftCorner<3, 3>());
  return xi;
}

namespace {
// The coupling block Q(v, w) of the SE(3) left Jacobian (Barfoot, State Estimation for
// Robotics, eq. 7.86), with series for small angles where the closed form cancels.
Eigen::Matrix3d q_block(const Eigen::Vector3d& v, const Eigen::Vector3d& w) {
  const double t2 = w.squaredNorm();
  const double t = std::sqrt(t2);
  const Eigen::Matrix3d V = SO3::hat(v);
  const Eigen::Matrix3d W = SO3::hat(w);
  double c1 = 0.0, c2 = 0.0, c3 = 0.0;
  if (t < 1e-2) {
    c1 = 1.0 / 6.0 - t2 / 120.0;
    c2 = 1.0 / 24.0 - t2 / 720.0;
    c3 = 1.0 / 120.0 - t2 / 2520.0;
  } else {
    const double s = std::sin(t), c = std::cos(t);
    c1 = (t - s) / (t2 * t);
    // t^2/2 + cos t - 1 with 1 - cos t = 2 sin^2(t/2): the plain difference carries an
    // absolute error ~eps that becomes ~eps |v| / t^2 in the Jacobian (1e-11 at t = 1e-2).
    const double sin_half = std::sin(0.5 * t);
    c2 = (t2 / 2.0 - 2.0 * sin_half * sin_half) / (t2 * t2);
    c3 = -0.5 * ((1.0 - t2 / 2.0 - c) / (t2 * t2) - 3.0 * (t - s - t2 * t / 6.0) / (t2 * t2 * t));
  }
  // Q = V/2 + c1 (WV + VW + WVW) + c2 (WWV + VWW - 3 WVW) + c3 (WVWW + WWVW), with the skew
  // products in closed form (d = w.v, u = w x v): WV = v w^T - d I, VW = w v^T - d I,
  // WVW = -d W, WWV = u w^T - d W, VWW = -w u^T - d W and WW = w w^T - t^2 I.
  const double d = w.dot(v);
  const Eigen::Vector3d u = w.cross(v);
  Eigen::Matrix3d WW = w * w.transpose();
  WW.diagonal().array() -= t2;
  Eigen::Matrix3d sym = v * w.transpose() + w * v.transpose();
  sym.diagonal().array() -= 2.0 * d;
  return 0.5 * V + c1 * (sym - d * W) + c2 * (u * w.transpose() - w * u.transpose() + d * W) -
         (2.0 * c3 * d) * WW;
}
}  // namespace

Matrix6d SE3::left_jacobian(const Tangent& xi) {
  const Eigen::Vector3d w = xi.tail<3>();
  const Eigen::Matrix3d J = SO3::left_jacobian(w);
  Matrix6d out = Matrix6d::Zero();
  out.topLeftCorner<3, 3>() = J;
  out.bottomRightCorner<3, 3>() = J;
  out.topRightCorner<3, 3>() = q_block(xi.head<3>(), w);
  return out;
}

Matrix6d SE3::left_jacobian_inverse(const Tangent& xi) {
  const Eigen::Vector3d w = xi.tail<3>();
  const Eigen::Matrix3d Ji = SO3::left_jacobian_inverse(w);
  Matrix6d out = Matrix6d::Zero();
  out.topLeftCorner<3, 3>() = Ji;
  out.bottomRightCorner<3, 3>() = Ji;
  out.topRightCorner<3, 3>() = -Ji * q_block(xi.head<3>(), w) * Ji;
  return out;
}

}  // namespace kestrel
