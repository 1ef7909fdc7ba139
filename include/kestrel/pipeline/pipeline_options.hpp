// Options of `kestrel run`: the real-time pipeline over a recorded EuRoC folder or a live V4L2
// stereo camera. YAML keys are the field names; file paths inside the config are relative to
// the config file's folder.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"
#include "kestrel/pipeline/camera_source_options.hpp"
#include "kestrel/pipeline/controller_options.hpp"
#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::pipeline {

enum class Pace {
  kFast,      ///< every frame as soon as the pipeline can take it (throughput)
  kRecorded,  ///< frames and IMU released at their recorded times (real-time behaviour)
};

enum class Source {
  kFolder,  ///< a recorded EuRoC folder: stereo pairs and the IMU (`input`)
  kCamera,  ///< the live V4L2 stereo camera (`camera`); no IMU: the fusion passes through
};

struct PipelineOptions {
  Source source = Source::kFolder;
  std::filesystem::path input;  ///< EuRoC folder (holding mav0/, or mav0 itself); folder source
  CameraSourceOptions camera;   ///< the camera source's options (`camera:` block)
  Pace pace = Pace::kFast;      ///< folder source only: a camera delivers at its own rate
  /// Full queues drop their oldest item (stale frames) instead of making the producer wait.
  /// Unset: true for a camera and for the recorded pace (real time), false for fast (offline,
  /// nothing lost).
  std::optional<bool> drop_stale;
  std::size_t frame_queue_capacity = 2;      ///< source -> depth, depth -> tracker
  std::size_t fusion_queue_capacity = 1024;  ///< IMU + tracker results -> fusion
  std::size_t state_queue_capacity = 64;     ///< fusion -> controller
  std::size_t max_frames = 0;  ///< 0: every stereo pair of the folder / until the camera stops
  /// The tracker's covariance treats pixels as independent; the fusion gets it times this
  /// (as flight/stereo_vision.hpp does).
  double vo_covariance_scale = 25.0;
  /// What each odometry measurement is relative to (`vo_reference: keyframe|previous_frame`;
  /// fusion/odometry_measurement.hpp, as `kestrel fly --vo-reference`).
  fusion::OdometryReference vo_reference = fusion::OdometryReference::kKeyframe;
  std::filesystem::path output = "trajectory.txt";  ///< fused trajectory (TUM), under --out

  sensor::BlockMatcherOptions matcher;
  odometry::DirectTrackerOptions tracker;
  fusion::FusionOptions fusion;  ///< IMU noise and T_body_cam are taken from the folder
  ControllerStageOptions controller;  ///< the controller stage (`controller:` block)
  /// The file load_yaml() read (empty when built in code): run-time errors of the camera name
  /// it with their field.
  std::filesystem::path config_file;

  [[nodiscard]] bool drops() const {
    return drop_stale.value_or(source == Source::kCamera || pace == Pace::kRecorded);
  }
  /// Loads a config file; unknown keys and bad values are InputErrors naming the file and
  /// field. Keys: source (folder|camera), input (folder), camera (a map, see
  /// CameraSourceOptions::from_yaml), pace (fast|recorded), drop_stale, frame_queue_capacity,
  /// fusion_queue_capacity, state_queue_capacity, max_frames, vo_covariance_scale, output,
  /// matcher_options / tracker_options / fusion_options (files), tracker (inline map),
  /// controller (a map, see ControllerStageOptions::from_yaml).
  static PipelineOptions load_yaml(const std::filesystem::path& path);
  /// Throws InputError for impossible values (zero capacities, non-positive scale).
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

}  // namespace kestrel::pipeline
