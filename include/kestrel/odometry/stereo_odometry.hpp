// Stereo odometry (thesis 2.4-2.5, 3.6-3.10): the stereo front end (rectify the raw pair when
// calibrated as raw, block-match the left disparity) and the direct tracker in disparity
// space. Lives in its own library (kestrel::stereo_odometry) so that the tracker itself
// depends on image/geometry only.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"

namespace kestrel::odometry {

/// The tracking of one stereo pair, with the matcher's health.
struct StereoTrackResult {
  TrackResult track;
  sensor::MatchStats match;
};

class StereoOdometry {
 public:
  /// A raw (distorted, unrectified) pair: every frame is rectified first.
  StereoOdometry(const sensor::StereoCalibration& calibration,
                 const sensor::BlockMatcherOptions& matcher_options,
                 const DirectTrackerOptions& tracker_options,
                 const sensor::RectifyOptions& rectify_options = {});
  /// An already rectified rig (rendered pairs): no remapping.
  StereoOdometry(const RectifiedStereo& rig, const sensor::BlockMatcherOptions& matcher_options,
                 const DirectTrackerOptions& tracker_options);
  /// A raw pair with any matcher (front_end.kind: sad, census, sgm) and rectification options;
  /// front_end.compute_depth is ignored (the tracker works in disparity space).
  StereoOdometry(const sensor::StereoCalibration& calibration,
                 const sensor::StereoFrontEndOptions& front_end,
                 const DirectTrackerOptions& tracker_options);

  /// Rectifies (if raw), matches and tracks the left view of one pair. Bad images (empty,
  /// wrong size or type) give a kInvalidInput result naming the problem; nothing is thrown for
  /// them.
  StereoTrackResult track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right);
  /// The same, tracking `tracking_image` instead of the left view: another image of the
  /// (rectified) left camera, such as the pattern-free view of an active sensor.
  StereoTrackResult track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right,
                          const cv::Mat& tracking_image);

  [[nodiscard]] const RectifiedStereo& rig() const { return front_end_.rig(); }
  /// Rotation from the raw left camera frame to the rectified one (identity without
  /// rectification): poses are of the rectified left camera.
  [[nodiscard]] Eigen::Matrix3d R_rect_left() const { return front_end_.R_rect_left(); }
  /// The last rectified left view and its disparity (kNoDisparity where none).
  [[nodiscard]] const cv::Mat& left_rectified() const { return frame_.left_rect; }
  [[nodiscard]] const cv::Mat& disparity() const { return frame_.disparity_px; }
  [[nodiscard]] const DirectTracker& tracker() const { return tracker_; }
  [[nodiscard]] const sensor::StereoFrontEnd& front_end() const { return front_end_; }

 private:
  sensor::StereoFrontEnd front_end_;
  DirectTracker tracker_;
  sensor::StereoDepthFrame frame_;
};

}  // namespace kestrel::odometry
