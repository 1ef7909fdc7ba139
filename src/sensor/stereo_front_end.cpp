// The stereo front end: rectification -> stereo matching -> disparity (and depth).
#include "kestrel/sensor/stereo_front_end.hpp"

#include <chrono>
#include <stdexcept>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"

namespace kestrel::sensor {

namespace {

StereoMatcher make_matcher(const StereoFrontEndOptions& options, const RectifiedStereo& rig) {
  const BlockMatcherOptions& block = options.matcher;
  const StereoMatcherKind kind = options.kind.value_or(
      block.cost == MatchingCost::kCensus ? StereoMatcherKind::kCensus : StereoMatcherKind::kSad);
  SgmOptions sgm = options.sgm;
  sgm.min_disparity = block.min_disparity;
  sgm.max_disparity = block.max_disparity;
  try {
    return StereoMatcher(kind, block, sgm, rig);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("stereo matcher (") + std::string(to_string(kind)) +
                     "): " + e.what());
  }
}

}  // namespace

StereoFrontEnd::StereoFrontEnd(const StereoCalibration& calibration,
                               const StereoFrontEndOptions& options)
    : options_(options),
      rectifier_(std::in_place, calibration, options.rectify),
      rig_(rectifier_->rig()),
      matcher_(make_matcher(options, rig_)) {}

StereoFrontEnd::StereoFrontEnd(const RectifiedStereo& rig, const StereoFrontEndOptions& options)
    : options_(options), rig_(rig), matcher_(make_matcher(options, rig)) {}

Eigen::Matrix3d StereoFrontEnd::R_rect_left() const {
  return rectifier_ ? rectifier_->R_rect_left() : Eigen::Matrix3d::Identity();
}

void StereoFrontEnd::process(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right,
                             StereoDepthFrame& out) {
  out.t_ns = t_ns;
  auto start = std::chrono::steady_clock::now();
  if (rectifier_) {
    rectifier_->rectify(left, right, out.left_rect, out.right_rect);
  } else {
    out.left_rect = left;  // headers: no copy
    out.right_rect = right;
  }
  out.rectify_ms = ms_since(start);

  start = std::chrono::steady_clock::now();
  out.match = matcher_.match(out.left_rect, out.right_rect, out.disparity_px);
  if (options_.compute_depth) {
    disparity_to_depth(out.disparity_px, rig_, out.depth_m);
  } else {
    out.depth_m.release();
  }
  out.match_ms = ms_since(start);
}

}  // namespace kestrel::sensor
