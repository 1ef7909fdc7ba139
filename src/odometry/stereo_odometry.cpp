// Stereo odometry: the stereo front end, then disparity-space tracking.
#include "kestrel/odometry/stereo_odometry.hpp"

#include "kestrel/core/error.hpp"

namespace kestrel::odometry {

namespace {

sensor::StereoFrontEndOptions front_end_options(const sensor::BlockMatcherOptions& matcher,
                                                const sensor::RectifyOptions& rectify) {
  sensor::StereoFrontEndOptions o;
  o.matcher = matcher;
  o.rectify = rectify;
  return o;  // disparity only: the tracker works in disparity space
}

sensor::StereoFrontEndOptions disparity_only(sensor::StereoFrontEndOptions o) {
  o.compute_depth = false;
  return o;
}

}  // namespace

StereoOdometry::StereoOdometry(const sensor::StereoCalibration& calibration,
                               const sensor::BlockMatcherOptions& matcher_options,
                               const DirectTrackerOptions& tracker_options,
                               const sensor::RectifyOptions& rectify_options)
    : front_end_(calibration, front_end_options(matcher_options, rectify_options)),
      tracker_(front_end_.rig(), tracker_options) {}

StereoOdometry::StereoOdometry(const RectifiedStereo& rig,
                               const sensor::BlockMatcherOptions& matcher_options,
                               const DirectTrackerOptions& tracker_options)
    : front_end_(rig, front_end_options(matcher_options, {})), tracker_(rig, tracker_options) {}

StereoOdometry::StereoOdometry(const sensor::StereoCalibration& calibration,
                               const sensor::StereoFrontEndOptions& front_end,
                               const DirectTrackerOptions& tracker_options)
    : front_end_(calibration, disparity_only(front_end)),
      tracker_(front_end_.rig(), tracker_options) {}

StereoTrackResult StereoOdometry::track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right) {
  return track(t_ns, left, right, cv::Mat());
}

StereoTrackResult StereoOdometry::track(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right,
                                        const cv::Mat& tracking_image) {
  StereoTrackResult out;
  try {
    front_end_.process(t_ns, left, right, frame_);
  } catch (const InputError& e) {
    out.track.t_ns = t_ns;
    out.track.failure = TrackFailure::kInvalidInput;
    out.track.failure_detail = e.what();
    return out;
  }
  out.match = frame_.match;
  const cv::Mat& image = tracking_image.empty() ? frame_.left_rect : tracking_image;
  out.track = tracker_.track(DisparityFrame{t_ns, image, frame_.disparity_px});
  return out;
}

}  // namespace kestrel::odometry
