// Pinhole camera with radial-tangential (Brown-Conrady / OpenCV "plumb bob") distortion,
// thesis 2.2. Pixel centres are at integer coordinates; (cx, cy) is the principal point.
#pragma once

#include <Eigen/Core>
#include <string>

namespace kestrel {

/// Distortion coefficients in OpenCV's order k1, k2, p1, p2, k3.
struct RadTanDistortion {
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  [[nodiscard]] bool is_zero() const {
    return k1 == 0.0 && k2 == 0.0 && p1 == 0.0 && p2 == 0.0 && k3 == 0.0;
  }
};

struct PinholeIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;
};

class PinholeCamera {
 public:
  PinholeCamera() = default;
  /// Throws std::invalid_argument for non-positive or non-finite focal lengths, a
  /// non-positive image size, or a non-finite principal point or distortion coefficient.
  explicit PinholeCamera(const PinholeIntrinsics& k, const RadTanDistortion& d = {});

  [[nodiscard]] double fx() const { return k_.fx; }
  [[nodiscard]] double fy() const { return k_.fy; }
  [[nodiscard]] double cx() const { return k_.cx; }
  [[nodiscard]] double cy() const { return k_.cy; }
  [[nodiscard]] int width() const { return k_.width; }
  [[nodiscard]] int height() const { return k_.height; }
  [[nodiscard]] const PinholeIntrinsics& intrinsics() const { return k_; }
  [[nodiscard]] const RadTanDistortion& distortion() const { return d_; }
  [[nodiscard]] bool has_distortion() const { return !d_.is_zero(); }
  [[nodiscard]] Eigen::Matrix3d K() const;

  /// Camera-frame point (z > 0) to distorted pixel.
  [[nodiscard]] Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const;
  /// Distorted pixel and depth Z (along the optical axis) to camera-frame point.
  [[nodiscard]] Eigen::Vector3d unproject(const Eigen::Vector2d& uv, double depth_m) const;
  /// Normalised image coordinates (x/z, y/z) through the distortion model.
  [[nodiscard]] Eigen::Vector2d distort(const Eigen::Vector2d& xn) const;
  /// Inverse of distort() by Gauss-Newton with the analytic 2x2 Jacobian; converges to
  /// 1e-12 within the field of view of real lenses (tested on EuRoC's strong distortion).
  [[nodiscard]] Eigen::Vector2d undistort(const Eigen::Vector2d& xd) const;
  /// Distorted pixel to the pixel of the same ray in the undistorted camera (same K).
  [[nodiscard]] Eigen::Vector2d undistort_pixel(const Eigen::Vector2d& uv) const;

  /// The same intrinsics without distortion: the camera of an undistorted image.
  [[nodiscard]] PinholeCamera without_distortion() const;
  /// Intrinsics of an image scaled by `s` (pyramid levels, s = 0.5 per level), keeping
  /// pixel centres consistent: c' = (c + 0.5) s - 0.5.
  [[nodiscard]] PinholeCamera scaled(double s) const;

  [[nodiscard]] std::string describe() const;

 private:
  PinholeIntrinsics k_;
  RadTanDistortion d_;
};

/// A rectified stereo pair (thesis 2.4): both views share f, (cu, cv); the right camera sits
/// `baseline_m` along +x of the left. Disparity d = uL - uR > 0; depth Z = B f / d (eq. 2.9).
struct RectifiedStereo {
  double f = 0.0;
  double cu = 0.0;
  double cv = 0.0;
  double baseline_m = 0.0;
  int width = 0;
  int height = 0;

  /// A rig of `width` x `height` pixels with its principal point at the image centre
  /// ((width - 1) / 2, (height - 1) / 2), as rendered pairs have it.
  [[nodiscard]] static RectifiedStereo centred(int width, int height, double f_px,
                                               double baseline_m) {
    return {f_px,
            0.5 * static_cast<double>(width - 1),
            0.5 * static_cast<double>(height - 1),
            baseline_m,
            width,
            height};
  }

  [[nodiscard]] double depth_from_disparity(double d_px) const { return baseline_m * f / d_px; }
  [[nodiscard]] double disparity_from_depth(double z_m) const { return baseline_m * f / z_m; }
  /// The (distortion-free) left camera.
  [[nodiscard]] PinholeCamera left() const;
  /// Throws std::invalid_argument unless f, baseline and size are positive and f, baseline,
  /// cu, cv finite.
  void validate() const;
};

}  // namespace kestrel
