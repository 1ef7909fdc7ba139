// Rolling-shutter rectification of a rotating camera's images (Ringaby & Forssen, IJCV 2012;
// Kerl et al., ICCV 2015 model the same effect in RGB-D odometry): each row of a rolling-shutter
// image is exposed at its own time, so under a rotation rate w the image is sheared and
// stretched. The maps resample the raw (distorted) image to the undistorted one a global shutter
// would take at the middle row's time: undistortion and rectification in one remap. Rotation
// only: over one readout (~30 ms) a hand-held or flying camera's translation moves the image
// by a fraction of what its rotation does.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/image/interpolation.hpp"

namespace kestrel::image {

class RollingShutterRectifier {
 public:
  /// `camera`: the raw images' camera (with its lens distortion, if any); the output images
  /// are those of camera.without_distortion(). `readout_s`: time from the first row's exposure
  /// to the last row's (> 0). Throws std::invalid_argument otherwise. `interpolation`: how the
  /// intensity is resampled; it should match how the tracker samples the rectified images. Both
  /// images of a pair go through different maps, so each pixel is smoothed by an amount that
  /// depends on its fractional source position, and a tracker sampling more sharply than the
  /// rectifier sees that pattern as structure (docs/odometry.md, "bicubic sampling on the
  /// finest level", has the rendered test's errors for each pairing).
  RollingShutterRectifier(const PinholeCamera& camera, double readout_s,
                          Interpolation interpolation = Interpolation::kBilinear);

  /// Builds the maps for the rotation rate `omega_rad_s` (camera frame, right-multiplied:
  /// R_world_cam(t) = R_world_cam(t_mid) exp(omega (t - t_mid))). Row v was exposed at
  /// s = readout (v - v_mid) / height from t_mid and saw the ray r of the global image at t_mid
  /// as exp(omega s)^T r (s taken at the output row: the correction is a few pixels, its
  /// change of row a fraction of one). A zero rate gives the plain undistortion maps.
  void set_rotation_rate(const Eigen::Vector3d& omega_rad_s);

  /// Bilinear or bicubic (OpenCV's, a = -0.75) resampling, replicated border, of a raw
  /// intensity image.
  void rectify_intensity(const cv::Mat& raw, cv::Mat& out) const;
  /// Nearest-neighbour resampling of a raw depth map (0 outside): interpolating depth would
  /// invent surfaces between foreground and background.
  void rectify_depth(const cv::Mat& raw, cv::Mat& out) const;

 private:
  PinholeCamera camera_;
  double readout_s_ = 0.0;
  Interpolation interpolation_ = Interpolation::kBilinear;
  cv::Mat map_x_, map_y_;  // CV_32FC1, the image's size: output pixel -> raw pixel
};

}  // namespace kestrel::image
