// The real-time pipeline: the thesis' components as stages on their own threads, joined by
// bounded queues that drop stale frames rather than fall behind:
//
//   source (EuRoC folder: decode pairs, stream IMU; or the V4L2 stereo camera: pairs only)
//     -> depth (rectify + block match)
//     -> tracker (disparity-space DirectTracker) -> fusion (FusionEngine: IMU + relative poses)
//     -> controller (safety supervisor -> position controller -> limits -> watchdog -> PWM
//        mapper, as `kestrel fly`; the pulses are recorded: no flight controller attached)
//   source --IMU--> fusion
//
// With the camera source there is no IMU: the fusion stage passes the odometry through
// (PipelineReport::fusion_pass_through) instead of running the EKF, and the controller does
// not fly those states unless the config allows it (controller.allow_unfused): it records the
// disarmed PWM for each (PipelineReport::controller_disarmed).
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "kestrel/driver/device_io.hpp"
#include "kestrel/driver/stereo_capture.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/pipeline/controller_log.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "kestrel/pipeline/stage_stats.hpp"

namespace kestrel::pipeline {

struct PipelineReport {
  std::vector<StageStats> stages;  ///< source, depth, tracker, fusion, controller
  /// Image pair in (source hands it on) -> fused state out of the fusion, per state.
  std::vector<double> end_to_end_ms;
  std::vector<fusion::FusedState> states;  ///< what the controller received, in order
  /// The controller's outputs in order: one per state (flown, stale or disarmed), plus one per
  /// silence_check_s without a state (the watchdog's output).
  std::vector<ControllerRecord> controller;
  /// Unfused states (camera source) and allow_unfused off: every output is motors off.
  bool controller_disarmed = false;
  std::size_t stereo_pairs = 0;      ///< pairs the source emitted
  std::string matcher;               ///< the stereo matcher that ran, its options
  double mean_disparity_fill = 0.0;  ///< share of pixels with a disparity, per pair
  std::size_t imu_samples = 0;       ///< IMU samples the source emitted
  fusion::FusionCounters fusion_counters;
  /// The fusion's options as run: with the folder's IMU noise and T_body_cam, reorder 0.
  fusion::FusionOptions fusion_options;
  bool interrupted = false;  ///< stopped early by the stop flag
  double wall_s = 0.0;
  RectifiedStereo rig;

  /// Camera source: no IMU, so no EKF. `states` are then the odometry's poses of the rectified
  /// left camera (world: that camera at the first tracked pair; sigma NaN), not fused body
  /// poses, and fusion_counters / fusion_options are unused.
  bool fusion_pass_through = false;
  /// Camera source: how the capture went (frames, truncated / corrupted / out-of-order ones,
  /// frames the driver lost, and why it ended: count, Ctrl-C, unplugged, stalled, failed).
  std::optional<driver::CaptureReport> camera;
  driver::DeviceInfo camera_info;      ///< camera source: the device
  driver::StreamFormat camera_format;  ///< camera source: the format it agreed to
};

/// What a run uses besides its options.
struct PipelineEnvironment {
  /// The camera's system calls; null: the real ones (tests pass a stand-in device).
  std::shared_ptr<driver::DeviceIo> camera_io;
  /// The camera's problem frames are logged here (the first few of each kind); null: silent.
  std::ostream* log = nullptr;
};

/// Runs the whole folder (or options.max_frames pairs) and returns when every stage has
/// finished. `stop` (may be null), when set, ends the run early and cleanly: the source stops,
/// queues close, the stages drain what they hold. A stage's exception is rethrown after all
/// threads are joined. Throws InputError for a missing or malformed folder.
/// Camera source: runs until max_frames good frames, `stop`, or the camera ends the capture
/// (unplugged, stalled, failed: a normal return, see PipelineReport::camera). A device that
/// cannot be opened or configured is an InputError naming the config file, the field and the
/// device path.
PipelineReport run_pipeline(const PipelineOptions& options, const std::atomic<bool>* stop = nullptr,
                            const PipelineEnvironment& environment = {});

}  // namespace kestrel::pipeline
