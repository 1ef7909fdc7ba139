// The vehicle's vision in the closed loop, every stage the real one: the active-stereo pair is
// rendered from the true camera pose (projector on the rig), block-matched to disparity,
// turned into depth (Z = B f / d, thesis eq. 2.9) and tracked by the direct odometry; each
// tracked frame gives the fusion a relative camera motion with its covariance.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/relocalizer.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"
#include "kestrel/sim/exposure.hpp"
#include "kestrel/sim/projector_light.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scene.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::flight {

/// The projector of the flying rig: ProjectorOptions' defaults without shadow rays.
sim::ProjectorOptions rig_projector_options();

/// The sensor head and its processing. Defaults: the MT9V024 pair of the thesis binned to
/// 376 x 240 (74 deg horizontal field of view), 12 cm baseline, looking forward 10 cm ahead of
/// the body origin, projector between the cameras.
struct StereoVisionOptions {
  int width = 376;
  int height = 240;
  double f_px = 250.0;
  double baseline_m = 0.12;
  /// Left camera's optical frame (x right, y down, z forward) in the body frame (x forward,
  /// y left, z up).
  SE3 T_body_cam = SE3(SO3(), Eigen::Vector3d(0.10, 0.0, 0.0)) * sim::forward_camera_mount();
  sim::ProjectorMode projector_mode = sim::ProjectorMode::kAmbientAndPattern;
  /// What the odometry tracks. true: the left view without the pattern, as with an infrared
  /// (or strobed) projector that the stereo pair sees and the tracking image does not (thesis
  /// 5.2's future work; a Kinect-like head). false: the pattern-lit left view itself, as with
  /// the thesis' visible projector: the pattern moves with the rig, breaking brightness
  /// constancy and pulling the alignment towards zero motion (docs/flight.md measures it).
  /// Ignored for kOff; kDarkRoom always tracks the lit view (there is no other light).
  bool track_without_pattern = true;
  sim::ProjectorOptions projector = rig_projector_options();
  sensor::PatternOptions pattern;
  /// Camera noise (grey levels) of both views.
  double intensity_sigma = 2.0;
  sensor::BlockMatcherOptions matcher;  ///< its min/max_disparity are every matcher's range
  /// The stereo matcher (sad, census, sgm); unset: the block matcher with matcher.cost.
  std::optional<sensor::StereoMatcherKind> matcher_kind;
  sensor::SgmOptions sgm;  ///< matcher_kind sgm (the range is matcher's)
  odometry::DirectTrackerOptions tracker = odometry::stereo_head_tracker_options();
  /// The tracker's covariance is sigma^2 (J^T W J)^-1, which treats every pixel's residual
  /// as independent; neighbouring residuals are not, so the fusion gets it times this factor.
  double covariance_scale = 25.0;
  /// What each measurement is relative to (fusion/odometry_measurement.hpp; docs/flight.md
  /// compares the two in the closed loop).
  fusion::OdometryReference measurement_reference = fusion::OdometryReference::kKeyframe;
  /// Frames further apart than this (odometry switched off, a stall): the tracker restarts.
  double max_frame_gap_s = 0.2;
  /// After such a gap, relocalise the first frame against the frame the filter holds its clone
  /// of (the last one before the gap that started a new reference): a measurement across the
  /// gap ties the pose after it to the one before, where the restart alone leaves the drift
  /// of the gap in the estimate for good (docs/flight.md, "Re-localising after an odometry
  /// outage"). If the relocalisation fails its checks, the restart is as without it.
  bool relocalize_after_gap = true;
  odometry::RelocalizerOptions relocalizer;
  /// The relocalisation's prior (PoseEstimate) covers this many position standard deviations
  /// of the estimate after the gap, and at least min_translation_m; its rotation radius is
  /// rotation_deg (the gyro's attitude drifts far less over a gap than the position).
  double relocalization_prior_sigmas = 3.0;
  double relocalization_prior_min_translation_m = 0.10;
  double relocalization_prior_rotation_deg = 3.0;

  [[nodiscard]] RectifiedStereo rig() const;
  void validate() const;  ///< throws std::invalid_argument naming the field
  [[nodiscard]] std::string describe() const;
};

/// What one camera frame gave.
struct VisionFrame {
  TimeNs t_ns = 0;
  odometry::TrackResult track;
  /// The relative motion for the fusion (fusion::OdometryMeasurements::next(): with the
  /// keyframe reference a failed frame, and the first after a restart, give one that only
  /// moves the filter's clone there; with the previous-frame reference a failed frame none).
  std::optional<fusion::RelativePoseMeasurement> measurement;
  /// The first frame after a gap, when relocalize_after_gap is on and a reference was kept:
  /// the relocalisation against it (when ok, `measurement` is its measurement).
  std::optional<odometry::RelocalizationResult> relocalization;
  TimeNs relocalization_reference_ns = 0;  ///< the time stamp of the frame relocalised against
  double relocalization_ms = 0.0;          ///< its time (included in track_ms)
  double depth_fill = 0.0;                 ///< share of pixels with a disparity
  double render_ms = 0.0, match_ms = 0.0, track_ms = 0.0;
  double expose_ms = 0.0;  ///< motion blur and rolling shutter (included in render_ms)
};

/// The body's motion while the frame is taken (for the exposure effects).
struct BodyTwist {
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();
};

/// The on-board estimate of the body's pose at a frame (the filter's, carried to the frame by
/// the IMU) and its position uncertainty: after a gap, the relocalisation searches its matches
/// around the motion this predicts since the reference frame.
struct PoseEstimate {
  SE3 T_world_body;
  double position_sigma_m = 0.0;  ///< the largest standard deviation of the position
};

class StereoVision {
 public:
  /// Throws std::invalid_argument for invalid options.
  StereoVision(const sim::Scene& scene, const StereoVisionOptions& options, std::uint64_t seed);
  ~StereoVision();
  StereoVision(const StereoVision&) = delete;
  StereoVision& operator=(const StereoVision&) = delete;

  /// Renders, matches and tracks the frame the cameras take at t_ns from T_world_body. With a
  /// twist and active exposure options (set_exposure), the rendered views get the motion blur
  /// and rolling shutter of that motion (sim::expose), t_ns being the middle row's
  /// mid-exposure.
  /// `estimate` (may be null): the on-board estimate at this frame, kept with a relocalisation
  /// reference and used as the relocalisation's prior after a gap (without one, on either
  /// frame, the relocalisation searches the whole image).
  VisionFrame process(TimeNs t_ns, const SE3& T_world_body, const BodyTwist* twist = nullptr,
                      const PoseEstimate* estimate = nullptr);
  void set_exposure(const sim::ExposureOptions& exposure) { exposure_ = exposure; }

  [[nodiscard]] const StereoVisionOptions& options() const { return options_; }
  /// The last left stereo image, tracking image and depth (for figures).
  [[nodiscard]] const cv::Mat& last_left_gray() const { return left_gray_; }
  [[nodiscard]] const cv::Mat& last_tracking_gray() const { return tracking_gray_; }
  [[nodiscard]] const cv::Mat& last_depth_m() const { return depth_.depth_m; }

 private:
  void relocalize(const odometry::RgbdFrame& frame, const PoseEstimate* estimate, VisionFrame& out);

  StereoVisionOptions options_;
  RectifiedStereo rig_;
  std::shared_ptr<sim::ProjectorLight> projector_;
  bool tracking_view_;    // the odometry tracks the left view without the pattern
  sim::Scene lit_scene_;  // with the projector, unless it is the renderer's rig light
  sim::StereoRenderer renderer_;
  sim::RenderedFrame tracking_frame_;  // the left view without the pattern
  sensor::StereoFrontEnd front_end_;
  odometry::DirectTracker tracker_;
  sim::StereoFrame frame_;
  cv::Mat left_gray_, right_gray_, tracking_gray_;
  sensor::StereoDepthFrame depth_;
  fusion::OdometryMeasurements measurements_;
  std::optional<TimeNs> last_frame_ns_;
  // The relocaliser and its reference: a copy of the last frame whose measurement started a new
  // reference (the frame the filter clones, or anchors the keyframe on), with its depth.
  std::unique_ptr<odometry::Relocalizer> relocalizer_;
  std::optional<odometry::RgbdFrame> reference_;
  std::optional<PoseEstimate> reference_estimate_;
  sim::ExposureOptions exposure_;
  cv::Mat flow_, exposed_;
  sim::ExposureWorkspace expose_workspace_;
};

}  // namespace kestrel::flight
