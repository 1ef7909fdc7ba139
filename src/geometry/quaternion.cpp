// The thesis' quaternion formulas (appendices A and B), with the published errata fixed.
#include "kestrel/geometry/quaternion.hpp"

#include <stdexcept>

namespace kestrel::quat {

Quat multiply(const Quat& q1, const Quat& q2) {
  const double s1 = q1[0], a1 = q1[1], b1 = q1[2], c1 = q1[3];
  const double s2 = q2[0], a2 = q2[1], b2 = q2[2], c2 = q2[3];
  return {s1 * s2 - a1 * a2 - b1 * b2 - c1 * c2, s1 * a2 + a1 * s2 + b1 * c2 - c1 * b2,
          s1 * b2 - a1 * c2 + b1 * s2 + c1 * a2,
          // Eq. A.6 labels this row s3 by mistake; this is the k component.
          s1 * c2 + a1 * b2 - b1 * a2 + c1 * s2};
}

Quat conjugate(const Quat& q) { return {q[0], -q[1], -q[2], -q[3]}; }

Quat inverse(const Quat& q) {
  const double n2 = q.squaredNorm();
  if (n2 == 0.0) throw std::invalid_argument("quat::inverse: the zero quaternion has no inverse");
  return conjugate(q) / n2;  // eq. A.8 divides by |q|; the correct divisor is |q|^2
}

Eigen::Vector3d rotate(const Quat& q, const Eigen::Vector3d& p) {
  const Quat P{0.0, p.x(), p.y(), p.z()};
  const Quat r = multiply(multiply(q, P), conjugate(q));
  return r.tail<3>();
}

Eigen::Matrix3d to_rotation_matrix(const Quat& q) {
  const double s = q[0], a = q[1], b = q[2], c = q[3];
  Eigen::Matrix3d R;
  R << s * s + a * a - b * b - c * c, 2 * (a * b - s * c), 2 * (a * c + s * b), 2 * (a * b + s * c),
      s * s - a * a + b * b - c * c, 2 * (b * c - s * a),
      // Eq. B.1's (3,2) entry is misprinted; it is 2 s a + 2 b c.
      2 * (a * c - s * b), 2 * (s * a + b * c), s * s - a * a - b * b + c * c;
  return R;
}

Quat from_rotation_matrix(const Eigen::Matrix3d& R) {
  // Squares of the four components from the diagonal (eq. B.2) ...
  const double tr = R.trace();
  const Eigen::Vector4d sq{1.0 + tr, 1.0 + 2 * R(0, 0) - tr, 1.0 + 2 * R(1, 1) - tr,
                           1.0 + 2 * R(2, 2) - tr};
  Eigen::Index k = 0;
  sq.maxCoeff(&k);
  // ... then the largest one (well away from zero) fixes the others through the products of
  // eq. B.3 (corrected): s a = (r32 - r23)/4, s b = (r13 - r31)/4, s c = (r21 - r12)/4,
  // a b = (r21 + r12)/4, a c = (r13 + r31)/4, b c = (r32 + r23)/4.
  const double sa = R(2, 1) - R(1, 2), sb = R(0, 2) - R(2, 0), sc = R(1, 0) - R(0, 1);
  const double ab = R(1, 0) + R(0, 1), ac = R(0, 2) + R(2, 0), bc = R(2, 1) + R(1, 2);
  const double big = 0.5 * std::sqrt(std::max(sq[k], 0.0));
  const double f = 0.25 / big;
  Quat q;
  switch (k) {
    case 0:
      q = {big, sa * f, sb * f, sc * f};
      break;
    case 1:
      q = {sa * f, big, ab * f, ac * f};
      break;
    case 2:
      q = {sb * f, ab * f, big, bc * f};
      break;
    default:
      q = {sc * f, ac * f, bc * f, big};
      break;
  }
  if (q[0] < 0) q = -q;
  return q.normalized();
}

}  // namespace kestrel::quat
