// Options of `kestrel run`: the real-time pipeline over a recorded EuRoC folder or a live V4L2
// stereo camera. YAML keys are the field names; file paths inside the config are relative to
// the config file's folder.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"
#include "kestrel/pipeline/camera_source_options.hpp"
#include "kestrel/pipeline/controller_options.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"
#include "kestrel/sensor/stereo_matcher.hpp"

namespace kestrel::pipeline {

enum class Pace {
  kFast,      ///< every frame as soon as the pipeline can take it (throughput)
  kRecorded,  ///< frames and IMU released at their recorded times (real-time behaviour)
};

enum class Source {
  kFolder,  ///< a recorded EuRoC folder: stereo pairs and the IMU (`input`)
  kCamera,  ///< the live V4L2 stereo camera (`camera`); no IMU: the fusion passes through
};

/// "fast" / "recorded", "folder" / "camera": the names in a config.
std::string_view to_string(Pace pace);
std::string_view to_string(Source source);
/// The options-table hooks (io/option_fields.hpp); throw std::invalid_argument listing the
/// names.
void parse_option(std::string_view name, Pace& pace);
void parse_option(std::string_view name, Source& source);

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
  /// The stereo matcher (`matcher: sad|census|sgm`); unset: the block matcher with the cost of
  /// matcher_options (sad by default), what configs written before the key existed mean.
  std::optional<sensor::StereoMatcherKind> matcher_kind;
  /// Option files (`matcher_options`, `sgm_options`, `tracker_options`, `fusion_options`);
  /// empty: none. matcher_options' min/max_disparity are the range of every matcher.
  std::filesystem::path matcher_options_file;
  std::filesystem::path sgm_options_file;  ///< needs `matcher: sgm`
  std::filesystem::path tracker_options_file;
  std::filesystem::path fusion_options_file;

  sensor::BlockMatcherOptions matcher;
  sensor::SgmOptions sgm;  ///< sgm_options (its range is matcher's)
  /// tracker_options, or the inline `tracker:` map, over the stereo head's defaults (no far
  /// depth limit: odometry::stereo_head_tracker_options()).
  odometry::DirectTrackerOptions tracker = odometry::stereo_head_tracker_options();
  fusion::FusionOptions fusion;       ///< IMU noise and T_body_cam are taken from the folder
  ControllerStageOptions controller;  ///< the controller stage (`controller:` block)
  /// The file load_yaml() read (empty when built in code): run-time errors of the camera name
  /// it with their field.
  std::filesystem::path config_file;

  /// The config's keys (io/option_fields.hpp). Paths are as written; load_yaml() takes them
  /// from the config's folder and loads the files they name.
  template <typename V>
  void visit_fields(V&& v) {
    v("source", source);
    v("input", input);
    v("camera", camera);
    v("pace", pace);
    v("drop_stale", drop_stale);
    v("frame_queue_capacity", frame_queue_capacity);
    v("fusion_queue_capacity", fusion_queue_capacity);
    v("state_queue_capacity", state_queue_capacity);
    v("max_frames", max_frames);
    v("vo_covariance_scale", vo_covariance_scale);
    v("vo_reference", vo_reference);
    v("output", output);
    v("matcher", matcher_kind);
    v("matcher_options", matcher_options_file);
    v("sgm_options", sgm_options_file);
    v("tracker_options", tracker_options_file);
    v("fusion_options", fusion_options_file);
    v("tracker", tracker);
    v("controller", controller);
  }

  [[nodiscard]] bool drops() const {
    return drop_stale.value_or(source == Source::kCamera || pace == Pace::kRecorded);
  }
  /// Loads a config file; unknown keys and bad values are InputErrors naming the file and
  /// field. Keys: those of visit_fields(); `input` and `pace` are for the folder source,
  /// `camera` for the camera source; `tracker` and `tracker_options` exclude each other.
  static PipelineOptions load_yaml(const std::filesystem::path& path);
  /// Throws InputError "field '<name>': ..." for impossible values (zero capacities,
  /// non-positive scale).
  void validate() const;
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] std::string to_yaml() const;
  /// The stereo front end's matcher options: matcher_kind, matcher and sgm.
  [[nodiscard]] sensor::StereoFrontEndOptions front_end_options() const;
  /// The matcher that runs, one line (the chosen matcher's options).
  [[nodiscard]] std::string describe_matcher() const;
};

}  // namespace kestrel::pipeline
