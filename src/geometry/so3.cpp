// SO(3) exponential, logarithm and Jacobians with Taylor series near the identity.
#include "kestrel/geometry/so3.hpp"

#include <cmath>

#include "kestrel/geometry/quaternion.hpp"

namespace kestrel {
namespace {
// Below this angle the closed forms lose digits to cancellation; series are exact to
// double precision there (next term ~ theta^4 / 5040).
constexpr double kSmallAngle = 1e-4;

// [w]x^2 = w w^T - |w|^2 I: the square of a skew matrix without a 3x3 product.
Eigen::Matrix3d hat_squared(const Eigen::Vector3d& w, double norm2) {
  Eigen::Matrix3d W2 = w * w.transpose();
  W2.diagonal().array() -= norm2;
  return W2;
}

Eigen::Quaterniond canonical(const Eigen::Quaterniond& q) {
  Eigen::Quaterniond out = q.normalized();
  if (out.w() < 0) out.coeffs() = -out.coeffs();
  return out;
}
}  // namespace

SO3::SO3(const Eigen::Quaterniond& q) : q_(canonical(q)) {}

SO3 SO3::from_matrix(const Eigen::Matrix3d& R) {
  const quat::Quat q = quat::from_rotation_matrix(R);
  return SO3(Eigen::Quaterniond(q[0], q[1], q[2], q[3]));
}

SO3 SO3::exp(const Tangent& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  double w = 0.0;
  double k = 0.0;  // sin(theta/2) / theta
  if (theta < kSmallAngle) {
    w = 1.0 - theta2 / 8.0;
    k = 0.5 - theta2 / 48.0;
  } else {
    w = std::cos(0.5 * theta);
    k = std::sin(0.5 * theta) / theta;
  }
  return SO3(Eigen::Quaterniond(w, k * omega.x(), k * omega.y(), k * omega.z()));
}

SO3::Tangent SO3::log() const {
  const Eigen::Vector3d v = q_.vec();
  const double n = v.norm();
  const double w = q_.w();  // >= 0 by construction
  // theta = 2 atan2(n, w) is well conditioned everywhere, including theta = pi (w = 0).
  if (n < kSmallAngle * w) {
    // 2 atan(n/w)/n = (2/w) (1 - n^2/(3 w^2) + ...)
    const double r2 = (n * n) / (w * w);
    return (2.0 / w) * (1.0 - r2 / 3.0) * v;
  }
  return (2.0 * std::atan2(n, w) / n) * v;
}

double SO3::angle() const { return 2.0 * std::atan2(q_.vec().norm(), q_.w()); }

SO3 SO3::inverse() const { return SO3(q_.conjugate()); }

SO3 SO3::operator*(const SO3& other) const { return SO3(q_ * other.q_); }

Eigen::Vector3d SO3::operator*(const Eigen::Vector3d& p) const { return q_ * p; }

Eigen::Matrix3d SO3::matrix() const { return q_.toRotationMatrix(); }

Eigen::Matrix3d SO3::hat(const Tangent& w) {
  Eigen::Matrix3d W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return W;
}

SO3::Tangent SO3::vee(const Eigen::Matrix3d& W) { return {W(2, 1), W(0, 2), W(1, 0)}; }

Eigen::Matrix3d SO3::left_jacobian(const Tangent& w) {
  const double theta2 = w.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d W = hat(w);
  double a = 0.0, b = 0.0;  // (1 - cos t)/t^2, (t - sin t)/t^3
  if (theta < kSmallAngle) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    // 1 - cos t = 2 sin^2(t/2): the difference form loses ~eps/t^2 relative (1e-8 at 1e-4).
    const double sinc_half = std::sin(0.5 * theta) / (0.5 * theta);
    a = 0.5 * sinc_half * sinc_half;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * W + b * hat_squared(w, theta2);
}

So3ExpAndJacobianProduct SO3::exp_and_left_jacobian_times(const Tangent& w,
                                                          const Eigen::Vector3d& v) {
  // exp() and left_jacobian() with their shared half-angle terms: q = (cos(t/2), sin(t/2) w / t),
  // a = (1 - cos t) / t^2 = sinc(t/2)^2 / 2, b = (t - sin t) / t^3 with sin t = 2 sin(t/2)
  // cos(t/2); J_l v = v + a w x v + b w x (w x v).
  const double theta2 = w.squaredNorm();
  const double theta = std::sqrt(theta2);
  double qw = 0.0, k = 0.0, a = 0.0, b = 0.0;
  if (theta < kSmallAngle) {
    qw = 1.0 - theta2 / 8.0;
    k = 0.5 - theta2 / 48.0;
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double half = 0.5 * theta;
    const double s = std::sin(half), c = std::cos(half);
    qw = c;
    k = s / theta;
    const double sinc_half = s / half;
    a = 0.5 * sinc_half * sinc_half;
    b = (theta - 2.0 * s * c) / (theta2 * theta);
  }
  const Eigen::Vector3d wxv = w.cross(v);
  return {SO3(Eigen::Quaterniond(qw, k * w.x(), k * w.y(), k * w.z())),
          v + a * wxv + b * w.cross(wxv)};
}

Eigen::Matrix3d SO3::left_jacobian_inverse(const Tangent& w) {
  const double theta2 = w.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d W = hat(w);
  double c = 0.0;  // (1 - t sin t / (2 (1 - cos t))) / t^2 = (1 - (t/2) cot(t/2)) / t^2
  if (theta < kSmallAngle) {
    c = 1.0 / 12.0 + theta2 / 720.0;
  } else {
    // Half-angle form: 1 - cos t carries an absolute error ~eps that the subtraction from 1
    // and the division by t^2 magnify to ~eps / t^4 in c, i.e. ~eps / t^2 in J^-1 (2e-9 at
    // t = 2e-4). (t/2) cot(t/2) is accurate to a few ulps, leaving J^-1 accurate to ~eps.
    const double half = 0.5 * theta;
    c = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * W + c * hat_squared(w, theta2);
}

}  // namespace kestrel
