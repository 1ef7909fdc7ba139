// Hamilton quaternion algebra written out as in the thesis' appendices A and B, errata fixed
// (eq. A.6 k-component, eq. A.8 inverse, eqs. B.1 and B.3). The Lie-group classes use Eigen's
// quaternion; these functions are the thesis' formulas, tested against it.
#pragma once

#include <Eigen/Core>

namespace kestrel::quat {

/// q = [s, a, b, c] = s + a i + b j + c k (scalar first, as in the thesis).
using Quat = Eigen::Vector4d;

/// Hamilton product q1 q2 (thesis eq. A.6, k-row corrected).
Quat multiply(const Quat& q1, const Quat& q2);
Quat conjugate(const Quat& q);
/// q^-1 = q* / |q|^2 (thesis eq. A.8 corrected). Throws std::invalid_argument for q = 0.
Quat inverse(const Quat& q);
/// Rotate p by a unit quaternion: P' = q P q* (Hamilton-Cayley, thesis eq. A.10).
Eigen::Vector3d rotate(const Quat& q, const Eigen::Vector3d& p);
/// Euler-Rodrigues matrix of a unit quaternion (thesis eq. B.1, (3,2) entry corrected).
Eigen::Matrix3d to_rotation_matrix(const Quat& q);
/// Quaternion of a rotation matrix (thesis eq. B.3 corrected): the largest of |s|,|a|,|b|,|c|
/// is computed from the diagonal and the rest from off-diagonal sums, which stays accurate
/// at every angle including pi. The result has s >= 0.
Quat from_rotation_matrix(const Eigen::Matrix3d& R);

}  // namespace kestrel::quat
