// The stereo front end, the one place a stereo pair becomes a depth sensor's frame (thesis 2.4,
// 2.5): rectify the raw pair (when calibrated as raw), block-match the left disparity, and
// optionally turn it into metric depth (Z = B f / d, thesis eq. 2.9), timing each step. The
// stereo odometry, the on-board pipeline, the closed-loop flight and the ROS node all use it.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"
#include "kestrel/sensor/stereo_matcher.hpp"

namespace kestrel::sensor {

struct StereoFrontEndOptions {
  /// The block matcher's options (sad, census). Its disparity range is also the semi-global
  /// matcher's, so that switching `kind` keeps the range a configuration set.
  BlockMatcherOptions matcher;
  /// Which matcher: nullopt = the block matcher with `matcher.cost` (the default, and what
  /// configurations written before the choice existed mean), or a named one.
  std::optional<StereoMatcherKind> kind;
  /// The semi-global matcher's options (kind sgm); min/max_disparity come from `matcher`.
  SgmOptions sgm;
  RectifyOptions rectify;  ///< used only for a raw (calibrated, unrectified) pair
  /// Also fill StereoDepthFrame::depth_m (the RGB-D trackers need it; disparity-space tracking
  /// does not).
  bool compute_depth = false;
};

/// A configuration's choice of matcher, as the pipeline config, the ROS node's parameters and
/// `kestrel fly` give it: `matcher: sad|census|sgm`, `matcher_options: FILE` (the block
/// matcher's YAML; its min/max_disparity are every matcher's range) and `sgm_options: FILE`
/// (the semi-global matcher's YAML).
struct MatcherSelection {
  std::optional<StereoMatcherKind> kind;  ///< unset: the block matcher with the file's cost
  std::filesystem::path block_file;       ///< empty: BlockMatcherOptions' defaults
  std::filesystem::path sgm_file;         ///< empty: SgmOptions' defaults

  /// The names of the three keys in messages (`--stereo-matcher` for a flag, say).
  struct Keys {
    std::string kind = "matcher";
    std::string block_file = "matcher_options";
    std::string sgm_file = "sgm_options";
  };
};

/// Loads the selection's files into `options` (matcher, kind, sgm). Contradictions are
/// InputErrors "SOURCE: field 'KEY': ..." naming the configuration (`source`) and the key:
/// an SGM file without `matcher: sgm`, a `matcher` other than the block file's `cost`
/// (sad / census), an SGM file whose min/max_disparity differ from the range in use (the range
/// is the block matcher's, so that switching `matcher` keeps it). Errors inside a file name
/// that file and its field.
void apply_matcher_selection(const MatcherSelection& selection, const std::string& source,
                             StereoFrontEndOptions& options,
                             const MatcherSelection::Keys& keys = {});

/// One processed pair. The caller owns it: reusing one frame across pairs reuses its buffers
/// (no allocation per pair); a fresh one per pair lets frames travel through queues.
struct StereoDepthFrame {
  TimeNs t_ns = 0;
  cv::Mat left_rect;     ///< CV_8UC1 rectified left view (the input itself when already rectified)
  cv::Mat right_rect;    ///< CV_8UC1 rectified right view (likewise)
  cv::Mat disparity_px;  ///< CV_32FC1 left disparity, kNoDisparity where none
  cv::Mat depth_m;       ///< CV_32FC1 metres, 0 where none; empty unless compute_depth
  MatchStats match;
  double rectify_ms = 0.0;
  double match_ms = 0.0;  ///< matching and, with compute_depth, the depth conversion
};

class StereoFrontEnd {
 public:
  /// A raw (distorted, unrectified) pair: every frame is rectified first. Invalid matcher
  /// options are an InputError naming the matcher.
  StereoFrontEnd(const StereoCalibration& calibration, const StereoFrontEndOptions& options);
  /// An already rectified rig (rendered pairs, rectifying cameras): no remapping.
  StereoFrontEnd(const RectifiedStereo& rig, const StereoFrontEndOptions& options);

  /// Rectifies (if raw), matches and (optionally) converts one pair into `out`. Throws
  /// InputError for images of the wrong size or type.
  void process(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right, StereoDepthFrame& out);

  [[nodiscard]] const RectifiedStereo& rig() const { return rig_; }
  /// Rotation from the raw left camera frame to the rectified one (identity without
  /// rectification): depth and poses are of the rectified left camera.
  [[nodiscard]] Eigen::Matrix3d R_rect_left() const;
  [[nodiscard]] bool rectifies() const { return rectifier_.has_value(); }
  [[nodiscard]] const StereoMatcher& matcher() const { return matcher_; }
  [[nodiscard]] const StereoFrontEndOptions& options() const { return options_; }

 private:
  StereoFrontEndOptions options_;
  std::optional<StereoRectifier> rectifier_;
  RectifiedStereo rig_;
  StereoMatcher matcher_;
};

}  // namespace kestrel::sensor
