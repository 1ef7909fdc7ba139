// Stereo odometry front end (thesis 2.4-2.5, 3.6-3.10): rectify the raw pair (optional), block-
// match the left disparity, track the left view in disparity space. Lives in its own library
// (kestrel::stereo_odometry) so that the tracker itself depends on image/geometry only.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"

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

  /// Rectifies (if raw), matches and tracks one pair. Bad images (empty, wrong size or type)
  /// give a kInvalidInput result naming the problem; nothing is thrown for them.
  StereoTrackResult track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right);

  /// Matches one rectified pair and tracks `tracking_image` (the left view, or another image of
  /// the same camera: a pattern-free view of an active sensor) in disparity space.
  StereoTrackResult track_rectified(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right,
                                    const cv::Mat& tracking_image);

  [[nodiscard]] const RectifiedStereo& rig() const { return rig_; }
  /// Rotation from the raw left camera frame to the rectified one (identity without
  /// rectification): poses are of the rectified left camera.
  [[nodiscard]] Eigen::Matrix3d R_rect_left() const;
  /// The last rectified left view and its disparity (kNoDisparity where none).
  [[nodiscard]] const cv::Mat& left_rectified() const { return left_rect_; }
  [[nodiscard]] const cv::Mat& disparity() const { return disparity_; }
  [[nodiscard]] const DirectTracker& tracker() const { return tracker_; }
  [[nodiscard]] const sensor::BlockMatcher& matcher() const { return matcher_; }

 private:
  std::optional<sensor::StereoRectifier> rectifier_;
  RectifiedStereo rig_;
  sensor::BlockMatcher matcher_;
  DirectTracker tracker_;
  cv::Mat left_rect_, right_rect_, disparity_;
};

}  // namespace kestrel::odometry
