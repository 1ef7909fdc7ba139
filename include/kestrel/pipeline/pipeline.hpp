// The real-time pipeline (issue 7): the thesis' components as stages on their own threads,
// joined by bounded queues that drop stale frames rather than fall behind:
//
//   source (EuRoC folder: decode pairs, stream IMU) -> depth (rectify + block match)
//     -> tracker (disparity-space DirectTracker) -> fusion (FusionEngine: IMU + relative poses)
//     -> controller (records the fused state it would act on)
//   source --IMU--> fusion
//
// The controller is a pass-through here: it takes each fused state as a position controller
// would and records it (the trajectory, the end-to-end latency); no command is computed.
#pragma once

#include <atomic>
#include <cstddef>
#include <vector>

#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "kestrel/pipeline/stage_stats.hpp"

namespace kestrel::pipeline {

struct PipelineReport {
  std::vector<StageStats> stages;  ///< source, depth, tracker, fusion, controller
  /// Image pair in (source hands it on) -> fused state out of the fusion, per state.
  std::vector<double> end_to_end_ms;
  std::vector<fusion::FusedState> states;  ///< what the controller received, in order
  std::size_t stereo_pairs = 0;            ///< pairs the source emitted
  std::size_t imu_samples = 0;             ///< IMU samples the source emitted
  fusion::FusionCounters fusion_counters;
  /// The fusion's options as run: with the folder's IMU noise and T_body_cam, reorder 0.
  fusion::FusionOptions fusion_options;
  bool interrupted = false;  ///< stopped early by the stop flag
  double wall_s = 0.0;
  RectifiedStereo rig;
};

/// Runs the whole folder (or options.max_frames pairs) and returns when every stage has
/// finished. `stop` (may be null), when set, ends the run early and cleanly: the source stops,
/// queues close, the stages drain what they hold. A stage's exception is rethrown after all
/// threads are joined. Throws InputError for a missing or malformed folder.
PipelineReport run_pipeline(const PipelineOptions& options,
                            const std::atomic<bool>* stop = nullptr);

}  // namespace kestrel::pipeline
