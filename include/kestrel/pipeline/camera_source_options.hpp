// Options of the pipeline's camera source (`source: camera` in a `kestrel run` config): the V4L2
// stereo camera to open, the format to ask of it, how its packed Bayer-in-YUYV frames are
// decoded (the options of `kestrel capture`), and the stereo calibration the depth stage
// rectifies with. YAML keys are listed at from_yaml(); docs/pipeline.md.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "kestrel/sensor/rectification.hpp"

namespace kestrel::pipeline {

struct CameraSourceOptions {
  std::string device = "/dev/video0";
  /// Pixel format, size, frame rate (YAML `fps`, 0: the device's) and mmap buffers.
  driver::CameraOptions camera;
  /// left_byte, bayer, demosaic; its width/height are always the camera's.
  driver::StereoDecoderOptions decoder;
  /// No frame for this long ends the run as a stalled camera (the driver's poll deadline).
  double timeout_s = 2.0;
  /// The calibration files as given: one Kestrel `stereo_pair:` YAML, one EuRoC folder (its
  /// mav0/cam0 and cam1 sensor.yaml), or the two EuRoC sensor.yaml files (left, right).
  std::vector<std::filesystem::path> calibration_files;
  /// Loaded from calibration_files by from_yaml(); required to run (the raw views are
  /// rectified with it, so its image size must be the camera's).
  std::optional<sensor::StereoCalibration> calibration;

  /// The `camera:` map of `config`. Keys: device, pixel_format, width, height, fps, buffers,
  /// timeout_s, left_byte, bayer, demosaic, decoder_options (a file as `kestrel capture
  /// --decoder-options` takes, instead of left_byte/bayer/demosaic), calibration (required).
  /// Errors are InputErrors naming the config file and `camera.<key>`.
  static CameraSourceOptions from_yaml(const YAML::Node& map, const std::filesystem::path& config);
  /// Throws InputError naming `camera.<field>` (prefixed by `config` when not empty).
  void validate(const std::filesystem::path& config = {}) const;
  [[nodiscard]] std::string describe() const;
};

/// A raw stereo pair's calibration from what `camera.calibration` may name (see
/// CameraSourceOptions::calibration_files), through the existing loaders
/// (sensor::load_stereo_calibration, StereoCalibration::from_euroc_files).
sensor::StereoCalibration load_camera_calibration(const std::vector<std::filesystem::path>& files);

}  // namespace kestrel::pipeline
