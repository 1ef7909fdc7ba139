// Stereo calibration of a raw (distorted, unrectified) camera pair and its rectification with
// OpenCV (stereoRectify, initUndistortRectifyMap, remap), thesis 2.2 and 2.4: after it both
// views share f and (cu, cv), rows correspond, and the right camera sits at +B along x.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::io {
class EurocSequence;
}

namespace kestrel::sensor {

/// Two calibrated cameras (with lens distortion) and their relative pose.
struct StereoCalibration {
  PinholeCamera left;
  PinholeCamera right;
  SE3 T_left_right;  ///< maps points from the right camera's frame to the left one's

  /// From EuRoC cam0 (left) / cam1 (right) sensor.yaml: T_left_right = T_BS0^-1 T_BS1.
  /// Throws InputError naming the file and field that is missing.
  static StereoCalibration from_euroc(const io::EurocSequence& sequence);
  static StereoCalibration from_euroc_files(const std::filesystem::path& cam0_yaml,
                                            const std::filesystem::path& cam1_yaml);
  /// Throws std::invalid_argument for different image sizes or a zero baseline.
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// Kestrel's YAML for a raw pair:
///   stereo_pair:
///     left:  {width, height, fx, fy, cx, cy, distortion: [k1, k2, p1, p2, k3]}
///     right: {...}
///     T_left_right: [16 numbers, row-major 4x4]
/// Every field except `distortion` is required; errors name the file and field.
StereoCalibration load_stereo_calibration(const std::filesystem::path& path);
void save_stereo_calibration(const std::filesystem::path& path, const StereoCalibration& calib,
                             std::string_view command, bool force = false);

struct RectifyOptions {
  /// OpenCV's free scaling: 0 keeps only valid pixels (zoomed in), 1 keeps every source
  /// pixel (black borders), -1 OpenCV's default.
  double alpha = 0.0;
  /// Bilinear (true) or nearest-neighbour interpolation.
  bool bilinear = true;
};

/// Precomputed rectification maps of one calibration; rectify() only remaps (no allocation
/// once the outputs are sized).
class StereoRectifier {
 public:
  explicit StereoRectifier(const StereoCalibration& calibration, RectifyOptions options = {});

  /// The rectified rig (f, cu, cv, baseline, size) the outputs obey.
  [[nodiscard]] const RectifiedStereo& rig() const { return rig_; }
  /// Rotation from the original left camera frame to the rectified left frame (OpenCV R1).
  [[nodiscard]] const Eigen::Matrix3d& R_rect_left() const { return R_rect_left_; }
  [[nodiscard]] const StereoCalibration& calibration() const { return calibration_; }

  /// Throws InputError if the images do not have the calibrated size.
  void rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_rect,
               cv::Mat& right_rect) const;
  /// Rectified pixel of a raw pixel (for checks): undistort, rotate, project.
  [[nodiscard]] Eigen::Vector2d rectify_point(const Eigen::Vector2d& uv_raw, bool right) const;

 private:
  StereoCalibration calibration_;
  RectifyOptions options_;
  RectifiedStereo rig_;
  Eigen::Matrix3d R_rect_left_ = Eigen::Matrix3d::Identity();
  cv::Mat R1_, R2_, P1_, P2_;
  cv::Mat map_l1_, map_l2_, map_r1_, map_r2_;
};

}  // namespace kestrel::sensor
