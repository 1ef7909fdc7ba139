// SO(3): rotations stored as unit Hamilton quaternions, with exp/log, adjoint and the left
// Jacobian (thesis 3.3; errata to eq. 3.14 in shared/reference/README.md applied).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace kestrel {

struct So3ExpAndJacobianProduct;

/// A 3-D rotation. Value type; always holds a unit quaternion with non-negative w.
class SO3 {
 public:
  using Tangent = Eigen::Vector3d;

  /// Identity rotation.
  SO3() = default;
  /// From a quaternion (normalised here; any non-zero norm is accepted).
  explicit SO3(const Eigen::Quaterniond& q);
  /// From a rotation matrix; the nearest rotation is taken (thesis eq. B.3, Shepperd's method).
  static SO3 from_matrix(const Eigen::Matrix3d& R);

  /// Exponential map: rotation vector (axis * angle, rad) -> rotation. Exact near 0 and pi.
  static SO3 exp(const Tangent& omega);
  /// Logarithm: rotation -> rotation vector with angle in [0, pi].
  [[nodiscard]] Tangent log() const;

  [[nodiscard]] SO3 inverse() const;
  SO3 operator*(const SO3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const;

  [[nodiscard]] Eigen::Matrix3d matrix() const;
  [[nodiscard]] const Eigen::Quaterniond& unit_quaternion() const { return q_; }
  /// Adjoint on so(3): R * omega^ * R^T = (R omega)^, so Ad = R.
  [[nodiscard]] Eigen::Matrix3d adjoint() const { return matrix(); }
  /// Rotation angle in [0, pi].
  [[nodiscard]] double angle() const;

  /// [w]x, the skew-symmetric (cross-product) matrix.
  static Eigen::Matrix3d hat(const Tangent& w);
  static Tangent vee(const Eigen::Matrix3d& W);
  /// Left Jacobian J_l(w): exp(w + d) ~= exp(J_l(w) d) * exp(w).
  /// J_l = I + (1-cos t)/t^2 [w]x + (t - sin t)/t^3 [w]x^2 (the README's erratum of eq. 3.14).
  static Eigen::Matrix3d left_jacobian(const Tangent& w);
  static Eigen::Matrix3d left_jacobian_inverse(const Tangent& w);
  /// exp(w) and J_l(w) v together (SE(3)'s exponential: its rotation and translation), from one
  /// sine and cosine of the half angle, without forming J_l.
  static So3ExpAndJacobianProduct exp_and_left_jacobian_times(const Tangent& w,
                                                              const Eigen::Vector3d& v);
  /// Right Jacobian J_r(w) = J_l(-w): exp(w + d) ~= exp(w) * exp(J_r(w) d).
  static Eigen::Matrix3d right_jacobian(const Tangent& w) { return left_jacobian(-w); }
  static Eigen::Matrix3d right_jacobian_inverse(const Tangent& w) {
    return left_jacobian_inverse(-w);
  }

 private:
  Eigen::Quaterniond q_{Eigen::Quaterniond::Identity()};
};

/// SO3::exp_and_left_jacobian_times(w, v): exp(w) and J_l(w) v.
struct So3ExpAndJacobianProduct {
  SO3 rotation;
  Eigen::Vector3d jacobian_times_v;
};

}  // namespace kestrel
