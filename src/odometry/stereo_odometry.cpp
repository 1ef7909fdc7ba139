// Stereo odometry front end: rectification -> block matching -> disparity-space tracking.
#include "kestrel/odometry/stereo_odometry.hpp"

#include "kestrel/core/error.hpp"

namespace kestrel::odometry {

namespace {

sensor::BlockMatcher make_matcher(const sensor::BlockMatcherOptions& options,
                                  const RectifiedStereo& rig) {
  try {
    return sensor::BlockMatcher(options, rig);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("block matcher: ") + e.what());
  }
}

}  // namespace

StereoOdometry::StereoOdometry(const sensor::StereoCalibration& calibration,
                               const sensor::BlockMatcherOptions& matcher_options,
                               const DirectTrackerOptions& tracker_options,
                               const sensor::RectifyOptions& rectify_options)
    : rectifier_(std::in_place, calibration, rectify_options),
      rig_(rectifier_->rig()),
      matcher_(make_matcher(matcher_options, rig_)),
      tracker_(rig_, tracker_options) {}

StereoOdometry::StereoOdometry(const RectifiedStereo& rig,
                               const sensor::BlockMatcherOptions& matcher_options,
                               const DirectTrackerOptions& tracker_options)
    : rig_(rig), matcher_(make_matcher(matcher_options, rig)), tracker_(rig, tracker_options) {}

Eigen::Matrix3d StereoOdometry::R_rect_left() const {
  return rectifier_ ? rectifier_->R_rect_left() : Eigen::Matrix3d::Identity();
}

StereoTrackResult StereoOdometry::track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right) {
  if (!rectifier_) return track_rectified(t_ns, left, right, left);
  StereoTrackResult out;
  try {
    rectifier_->rectify(left, right, left_rect_, right_rect_);
  } catch (const InputError& e) {
    out.track.t_ns = t_ns;
    out.track.failure = TrackFailure::kInvalidInput;
    out.track.failure_detail = e.what();
    return out;
  }
  return track_rectified(t_ns, left_rect_, right_rect_, left_rect_);
}

StereoTrackResult StereoOdometry::track_rectified(TimeNs t_ns, const cv::Mat& left,
                                                  const cv::Mat& right,
                                                  const cv::Mat& tracking_image) {
  StereoTrackResult out;
  if (left.data != left_rect_.data) left_rect_ = left;  // a header: no copy
  try {
    out.match = matcher_.match(left, right, disparity_);
  } catch (const InputError& e) {
    out.track.t_ns = t_ns;
    out.track.failure = TrackFailure::kInvalidInput;
    out.track.failure_detail = e.what();
    return out;
  }
  out.track = tracker_.track(DisparityFrame{t_ns, tracking_image, disparity_});
  return out;
}

}  // namespace kestrel::odometry
