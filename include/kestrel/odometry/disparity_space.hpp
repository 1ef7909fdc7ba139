// Disparity space (thesis 2.4) and the direct tracker's warp and Jacobian in it (thesis 3.6-3.7),
// with the per-level baseline of thesis 3.10 instead of downsampled disparities.
//
// A rectified left pixel (u, v) with disparity d is the disparity-space point p = (x, y, d, 1),
// x = u - cu, y = v - cv. With Z = B f / d (eq. 2.9) it is the 3D point
//   P = Gamma^-1 p = (B / d) (x, y, f),   Gamma: (X, Y, Z, 1) ~ (f X / Z, f Y / Z, f B / Z, 1),
// and the warp of eq. 3.34 under the motion T = T_cur_ref is w(p, T) = pi(Gamma T Gamma^-1 p) + c,
// here with its third row d' = f B / Z' as well.
//
// Pyramid levels (thesis 3.10): level l has f_l = f / 2^l and c_l = (c + 0.5) / 2^l - 0.5 (the
// pixel centres of image::IntensityPyramid). Disparities are NOT halved per level: they stay in
// full-resolution pixels and the baseline is scaled instead, B_l = 2^l B, so that
// Z = B_l f_l / d = B f / d on every level.
//
// Jacobian (derived anew: the thesis' eq. 3.35 is garbled, see shared/reference/README.md): for
// a left-multiplied increment exp([v, w]) of the reference point, with beta = d / B (eq. 3.36),
// so that 1 / Z = beta / f:
//   du'/d[v, w] = [beta, 0, -beta x / f,   -x y / f, f + x^2 / f, -y]
//   dv'/d[v, w] = [0, beta, -beta y / f,   -f - y^2 / f, x y / f, x]
//   dd'/d[v, w] = [0, 0, -beta d / f,      -y d / f, x d / f, 0]
// and the photometric row grad I . d(u', v')/d[v, w] with alpha = x Ix + y Iy is
//   [beta Ix, beta Iy, -alpha beta / f,  -f Iy - alpha y / f, f Ix + alpha x / f, x Iy - y Ix].
// Tested against central differences of disparity_warp() (tests/odometry/test_disparity_space.cpp).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::odometry {

/// The rectified left camera of one pyramid level in disparity space (thesis 2.4, 3.10).
struct DisparitySpaceCamera {
  double f = 0.0;             ///< f_l = f / 2^l
  double cu = 0.0, cv = 0.0;  ///< c_l = (c + 0.5) / 2^l - 0.5
  double baseline_m = 0.0;    ///< B_l = 2^l B: disparities stay in full-resolution pixels

  /// Level `level` (0 = full resolution) of a rectified rig.
  static DisparitySpaceCamera at_level(const RectifiedStereo& rig, int level);

  /// Gamma^-1: the 3D point of pixel (u, v) with disparity d > 0 (eq. 2.9).
  [[nodiscard]] Eigen::Vector3d point(double u, double v, double d) const {
    const double s = baseline_m / d;
    return {s * (u - cu), s * (v - cv), s * f};
  }
  /// Gamma: (u, v, d) of a 3D point with Z > 0.
  [[nodiscard]] Eigen::Vector3d to_disparity_space(const Eigen::Vector3d& P) const {
    const double inv_z = 1.0 / P.z();
    return {f * P.x() * inv_z + cu, f * P.y() * inv_z + cv, f * baseline_m * inv_z};
  }
  /// Gamma as a 4x4 matrix on homogeneous points, pixel coordinates relative to c:
  /// Gamma (X, Y, Z, 1)^T = (Z / f) (x, y, d, 1)^T.
  [[nodiscard]] Eigen::Matrix4d gamma() const;
};

/// The warp of eq. 3.34 in disparity space: (u, v, d) of the reference to (u', v', d') in the
/// current frame, as the 4x4 map Gamma T_cur_ref Gamma^-1 on (x, y, d, 1).
Eigen::Vector3d disparity_warp(const DisparitySpaceCamera& camera, const Eigen::Vector3d& uvd,
                               const SE3& T_cur_ref);

/// d(u', v', d') / d[v, w] of disparity_warp(camera, (u, v, d), exp([v, w])) at [v, w] = 0.
Eigen::Matrix<double, 3, 6> disparity_warp_jacobian(const DisparitySpaceCamera& camera, double u,
                                                    double v, double d);

/// The 6 pose columns of the photometric Jacobian, grad I . d(u', v')/d[v, w] (the corrected
/// eq. 3.35), for a reference pixel (u, v) with disparity d and intensity gradient (gx, gy) per
/// pixel of its level.
inline Eigen::Matrix<double, 1, 6> disparity_photometric_pose_jacobian(
    const DisparitySpaceCamera& camera, double u, double v, double d, double gx, double gy) {
  const double x = u - camera.cu;
  const double y = v - camera.cv;
  const double f = camera.f;
  const double beta = d / camera.baseline_m;  // eq. 3.36: 1 / Z = beta / f
  const double alpha = x * gx + y * gy;       // eq. 3.36
  Eigen::Matrix<double, 1, 6> J;
  J << beta * gx, beta * gy, -alpha * beta / f, -f * gy - alpha * y / f, f * gx + alpha * x / f,
      x * gy - y * gx;
  return J;
}

/// The disparity of every pixel of pyramid level `level`, read from the full-resolution map
/// (thesis 3.10: disparities are not downsampled across occlusions; they stay in full-resolution
/// pixels and the baseline is scaled). A level pixel's value is the mean of the 2x2
/// full-resolution samples around its centre (the pixel itself on level 0) when all four have a
/// disparity and they spread by at most `max_relative_spread` of the largest; otherwise 0 (none).
/// On one plane the disparity is affine in (u, v), so that mean is the plane's disparity at the
/// centre. `disparity_px`: CV_32FC1, no disparity = <= 0, NaN or inf. `out` (CV_32FC1, of the
/// level's size W >> l x H >> l) is reused.
void disparity_at_level(const cv::Mat& disparity_px, int level, float max_relative_spread,
                        cv::Mat& out);

}  // namespace kestrel::odometry
