// Options of the pipeline's camera source (`source: camera` in a `kestrel run` config): the V4L2
// stereo camera to open, the format to ask of it, how its packed Bayer-in-YUYV frames are
// decoded (the options of `kestrel capture`), and the stereo calibration the depth stage
// rectifies with. YAML keys are those of visit_fields(); docs/pipeline.md.
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

/// `calibration:` as the options table reads and prints it: one path, or a list of them.
struct CalibrationFilesField {
  void read(const YAML::Node& node, std::vector<std::filesystem::path>& files) const;
  [[nodiscard]] std::string text(const std::vector<std::filesystem::path>& files) const;
};

struct CameraSourceOptions {
  std::string device = "/dev/video0";
  /// Pixel format, size, frame rate (YAML `fps`, 0: the device's) and mmap buffers.
  driver::CameraOptions camera;
  /// left_byte, bayer, demosaic; its width/height are always the camera's.
  driver::StereoDecoderOptions decoder;
  /// No frame for this long ends the run as a stalled camera (the driver's poll deadline).
  double timeout_s = 2.0;
  /// A file as `kestrel capture --decoder-options` takes, instead of left_byte/bayer/demosaic;
  /// empty: none.
  std::filesystem::path decoder_options_file;
  /// The calibration files: one Kestrel `stereo_pair:` YAML, one EuRoC folder (its
  /// mav0/cam0 and cam1 sensor.yaml), or the two EuRoC sensor.yaml files (left, right).
  std::vector<std::filesystem::path> calibration_files;
  /// Loaded from calibration_files by load_files(); required to run (the raw views are
  /// rectified with it, so its image size must be the camera's).
  std::optional<sensor::StereoCalibration> calibration;

  /// The keys of the `camera:` block (io/option_fields.hpp; PipelineOptions reads the block).
  template <typename V>
  void visit_fields(V&& v) {
    v("device", device);
    v("pixel_format", camera.pixel_format);
    v("width", camera.width);
    v("height", camera.height);
    v("fps", camera.rate_hz);
    v("buffers", camera.buffers);
    v("timeout_s", timeout_s);
    v("left_byte", decoder.left_byte);
    v("bayer", decoder.phase);
    v("demosaic", decoder.demosaic);
    v("decoder_options", decoder_options_file);
    v("calibration", calibration_files, CalibrationFilesField{});
  }

  /// Once the fields of `block`, the `camera:` map of `config`, are read: takes the file paths
  /// from the config's folder, loads the decoder options and the calibration (required), sizes
  /// the decoder as the camera and validates. Errors are InputErrors naming the config file and
  /// `camera.<key>`.
  void load_files(const YAML::Node& block, const std::filesystem::path& config);
  /// Throws InputError naming `camera.<field>` (prefixed by `config` when not empty).
  void validate(const std::filesystem::path& config = {}) const;
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] std::string to_yaml() const;
};

/// A raw stereo pair's calibration from what `camera.calibration` may name (see
/// CameraSourceOptions::calibration_files), through the existing loaders
/// (sensor::load_stereo_calibration, StereoCalibration::from_euroc_files).
sensor::StereoCalibration load_camera_calibration(const std::vector<std::filesystem::path>& files);

}  // namespace kestrel::pipeline
