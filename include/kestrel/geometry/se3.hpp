// SE(3): rigid-body motions as (SO3, t), twists ordered [v, w] (translation first), as in
// thesis eq. 3.10 with its erratum (v translational, w rotational).
#pragma once

#include "kestrel/geometry/so3.hpp"

namespace kestrel {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// A rigid motion T_a_b mapping points from frame b to frame a: p_a = R p_b + t.
class SE3 {
 public:
  using Tangent = Vector6d;  // [v, w]

  SE3() = default;
  SE3(const SO3& R, const Eigen::Vector3d& t) : so3_(R), t_(t) {}
  SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : so3_(q), t_(t) {}
  /// From a 4x4 homogeneous matrix (its rotation block is re-orthonormalised).
  static SE3 from_matrix(const Eigen::Matrix4d& T);

  /// exp([v, w]) = (exp(w), J_l(w) v).
  static SE3 exp(const Tangent& xi);
  [[nodiscard]] Tangent log() const;

  [[nodiscard]] SE3 inverse() const;
  SE3 operator*(const SE3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return so3_ * p + t_; }

  [[nodiscard]] const SO3& so3() const { return so3_; }
  [[nodiscard]] const Eigen::Vector3d& translation() const { return t_; }
  [[nodiscard]] Eigen::Matrix3d rotation_matrix() const { return so3_.matrix(); }
  [[nodiscard]] const Eigen::Quaterniond& unit_quaternion() const { return so3_.unit_quaternion(); }
  [[nodiscard]] Eigen::Matrix4d matrix() const;
  [[nodiscard]] Eigen::Matrix<double, 3, 4> matrix3x4() const;

  /// Adjoint on twists [v, w]: T exp(xi) T^-1 = exp(Ad_T xi); Ad = [[R, t^ R], [0, R]].
  [[nodiscard]] Matrix6d adjoint() const;

  /// 4x4 twist matrix [[w^, v], [0, 0]].
  static Eigen::Matrix4d hat(const Tangent& xi);
  static Tangent vee(const Eigen::Matrix4d& X);
  /// Left Jacobian of SE(3): exp(xi + d) ~= exp(J_l(xi) d) exp(xi) (Barfoot, eq. 7.85).
  static Matrix6d left_jacobian(const Tangent& xi);
  static Matrix6d left_jacobian_inverse(const Tangent& xi);

 private:
  SO3 so3_;
  Eigen::Vector3d t_{Eigen::Vector3d::Zero()};
};

}  // namespace kestrel
