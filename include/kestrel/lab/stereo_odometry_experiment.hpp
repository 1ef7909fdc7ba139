// Passive vs active stereo odometry on a rendered low-texture corridor: the same trajectory
// rendered passive (the scene's lights) and active (the projector's pattern), each block-matched
// and tracked in disparity space, and scored against the rendered ground truth.
// `kestrel lab stereo-experiment --odometry` runs it; docs/stereo.md has the figures.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "kestrel/eval/trajectory_metrics.hpp"
#include "kestrel/io/trajectory.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sim/projector_light.hpp"

namespace kestrel::lab {

struct StereoOdometryExperimentOptions {
  std::string scene = "corridor";      ///< a sim scene name (sim/scenes.hpp)
  std::string trajectory = "forward";  ///< a sim trajectory name (sim/smooth_trajectory.hpp)
  int frames = 90;
  double rate_hz = 15.0;  ///< 90 frames at 15 Hz: the first 6 s of "forward" (2 m)
  int width = 640;        ///< camera image size
  int height = 480;
  double f_px = 420.0;  ///< rectified focal length at width x height
  double baseline_m = 0.12;
  double intensity_sigma = 2.0;  ///< camera noise, grey levels
  /// The active run's lighting: kAmbientAndPattern (the corridor's lights stay on) or kDarkRoom.
  sim::ProjectorMode active_mode = sim::ProjectorMode::kAmbientAndPattern;
  sim::ProjectorOptions projector;
  sensor::PatternOptions pattern;
  sensor::BlockMatcherOptions matcher;
  odometry::DirectTrackerOptions tracker;
  std::uint64_t seed = 1;  ///< pattern, textures, noise
  /// When set, the passive and active sequences are also written as EuRoC/TUM folders
  /// (sim::SequenceWriter) under it: passive/, active/ (for `kestrel odometry --stereo`).
  std::filesystem::path write_sequences_to;
  bool force = false;  ///< SequenceWriter's force
  /// Polled between frames: once it is true the run ends early, with the frames done (Ctrl-C).
  const std::atomic<bool>* stop = nullptr;

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// One configuration tracked over the whole sequence.
struct StereoOdometryRun {
  std::string name;
  std::string description;
  Trajectory estimate;  ///< T_world_cam of the left camera, first frame = identity
  int frames = 0;
  int failures = 0;  ///< frames whose odometry::TrackResult is not ok (the prediction was reported)
  int keyframes = 0;
  double mean_fill = 0.0;     ///< block matcher fill rate (valid / pixels), mean over frames
  double mean_points = 0.0;   ///< reference points on the finest level, mean over tracked frames
  std::string first_failure;  ///< "frame K: reason: detail" of the first failure
  bool evaluated = false;     ///< ATE/RPE could be computed
  eval::AteResult ate;
  eval::RpeResult rpe;
  double final_error_m = 0.0;    ///< |p_est - p_gt| at the last frame, no alignment
  double final_error_deg = 0.0;  ///< rotation error at the last frame, no alignment
  double path_length_m = 0.0;    ///< ground-truth distance travelled
};

struct StereoOdometryExperimentResult {
  Trajectory groundtruth;  ///< T_world_cam of the left camera relative to the first frame
  /// passive; active (tracking the pattern-lit left view); active-depth (disparity from the
  /// pattern-lit pair, tracking the passive left view: a pattern the intensity camera does not
  /// see, e.g. infrared, or a strobed projector).
  std::vector<StereoOdometryRun> runs;
  bool stopped = false;  ///< ended early by StereoOdometryExperimentOptions::stop
};

/// Renders and tracks. Throws std::invalid_argument / InputError for invalid options.
StereoOdometryExperimentResult run_stereo_odometry_experiment(
    const StereoOdometryExperimentOptions& options);

/// One line per run: failures, fill, ATE, RPE, final drift.
std::string format_stereo_odometry_result(const StereoOdometryExperimentResult& result);

}  // namespace kestrel::lab
