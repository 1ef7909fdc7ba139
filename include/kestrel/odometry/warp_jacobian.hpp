// The Jacobian of the inverse-compositional photometric residual for one reference point
// (thesis 3.7, derived anew: eq. 3.35 is garbled, see shared/reference/README.md).
//
// Model: a reference pixel p with depth Z gives P = Z K^-1 p. The residual with gain/bias is
//   r = alpha * I_cur(pi(T_cur_ref P)) + beta - [(1 + dg) I_ref(pi(exp(d) P)) + db],
// where the increment (d, dg, db) acts on the reference side (inverse compositional), so
//   dr/d(d, dg, db) at 0 = -[ grad I_ref(p) dpi/dP [I, -P^],  I_ref(p),  1 ]  =: -J.
// Gauss-Newton: (J^T W J) delta = J^T W r. Update, from solving the model for I_ref(pi(Q)):
//   T_cur_ref <- T_cur_ref exp(-d),  alpha <- alpha / (1 + dg),  beta <- (beta - db) / (1 + dg).
#pragma once

#include <Eigen/Core>

namespace kestrel::odometry {

using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix8d = Eigen::Matrix<double, 8, 8>;

/// The 6 pose columns of J for a point P (reference camera frame) whose pixel has
/// intensity gradient (gx, gy) per pixel, with focal lengths fx, fy, for the twist [v, w].
inline Eigen::Matrix<double, 1, 6> photometric_pose_jacobian(const Eigen::Vector3d& P, double gx,
                                                             double gy, double fx, double fy) {
  const double inv_z = 1.0 / P.z();
  const double a = gx * fx * inv_z;                   // d I / d X
  const double b = gy * fy * inv_z;                   // d I / d Y
  const double c = -(a * P.x() + b * P.y()) * inv_z;  // d I / d Z
  Eigen::Matrix<double, 1, 6> J;
  // Translation: dP/dv = I. Rotation: dP/dw = -[P]x, so dI/dw = P x (a, b, c).
  J << a, b, c, P.y() * c - P.z() * b, P.z() * a - P.x() * c, P.x() * b - P.y() * a;
  return J;
}

/// The full 8-column row [pose, I_ref, 1].
inline Vector8d photometric_jacobian(const Eigen::Vector3d& P, double gx, double gy, double fx,
                                     double fy, double i_ref) {
  Vector8d J;
  J.head<6>() = photometric_pose_jacobian(P, gx, gy, fx, fy).transpose();
  J(6) = i_ref;
  J(7) = 1.0;
  return J;
}

/// The geometric (point-to-plane) residual of a reference point P with unit normal n (both in
/// the reference frame), against the current frame's 3D point Q_cur at P's warped pixel:
///   r_g = n . (T_ref_cur Q_cur - P).
/// With the update T_ref_cur <- exp(d) T_ref_cur (the same as the photometric residual's
/// T_cur_ref <- T_cur_ref exp(-d)) and Q_ref = T_ref_cur Q_cur, r_g(d) = n . (exp(d) Q_ref - P):
///   dr_g/dd = n^T [I, -Q_ref^] = [n, Q_ref x n] =: -J_g
/// for a fixed correspondence, and exactly (to first order) for a planar surface where the
/// correspondence slides along the plane. Q_ref -> P at convergence, but evaluating it at P
/// (a constant, IC-style J_g) fails far from it (a 4 deg roll stalls): J_g is computed per
/// iteration, 6 multiply-adds per point. Tested against central differences.
inline Eigen::Matrix<double, 1, 6> point_to_plane_pose_jacobian(const Eigen::Vector3d& Q_ref,
                                                                const Eigen::Vector3d& n) {
  Eigen::Matrix<double, 1, 6> J;
  J.head<3>() = -n.transpose();
  J.tail<3>() = -Q_ref.cross(n).transpose();
  return J;
}

}  // namespace kestrel::odometry
