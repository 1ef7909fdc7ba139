// Loading and checking the `camera:` block of a pipeline config, and the stereo calibration it
// names (through the sensor module's loaders: no parser of its own).
#include "kestrel/pipeline/camera_source_options.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

// Field `camera.<key>` (an empty key names the block itself).
InputError camera_field_error(const fs::path& config, const std::string& key,
                              const std::string& msg) {
  return io::field_error(config, key.empty() ? "camera" : "camera." + key, msg);
}

// The decoder options from their own file, which replaces the block's decoder keys and, being
// the frame's, gives the size; the block's width/height must then agree with it.
void load_decoder_file(const YAML::Node& block, const fs::path& config, CameraSourceOptions& o) {
  for (const char* key : {"left_byte", "bayer", "demosaic"}) {
    if (block[key]) {
      throw camera_field_error(config, "decoder_options",
                               std::string("excludes camera.") + key + " (give one or the other)");
    }
  }
  o.decoder = driver::StereoDecoderOptions::load_yaml(o.decoder_options_file);
  if ((block["width"] && o.camera.width != o.decoder.width) ||
      (block["height"] && o.camera.height != o.decoder.height)) {
    throw camera_field_error(
        config, "decoder_options",
        o.decoder_options_file.string() + " is for " + std::to_string(o.decoder.width) + "x" +
            std::to_string(o.decoder.height) + " frames, camera.width/height say " +
            std::to_string(o.camera.width) + "x" + std::to_string(o.camera.height));
  }
  o.camera.width = o.decoder.width;
  o.camera.height = o.decoder.height;
}

}  // namespace

sensor::StereoCalibration load_camera_calibration(const std::vector<fs::path>& files) {
  if (files.size() == 2) return sensor::StereoCalibration::from_euroc_files(files[0], files[1]);
  if (files.size() != 1) {
    throw InputError("expected one file or folder, or two EuRoC sensor.yaml files, got " +
                     std::to_string(files.size()));
  }
  const fs::path& path = files.front();
  if (!fs::exists(path)) throw InputError(path.string() + ": no such calibration file or folder");
  if (fs::is_directory(path)) {
    // An EuRoC folder (holding mav0/, or mav0 itself), as `kestrel disparity --calib` takes.
    const fs::path mav0 = fs::is_directory(path / "mav0") ? path / "mav0" : path;
    return sensor::StereoCalibration::from_euroc_files(mav0 / "cam0" / "sensor.yaml",
                                                       mav0 / "cam1" / "sensor.yaml");
  }
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["stereo_pair"]) return sensor::load_stereo_calibration(path);
  if (root.IsMap() && root["stereo"]) {
    // A rectified rig has no distortion nor relative pose: the camera's raw views cannot be
    // rectified with it.
    throw InputError(path, "stereo",
                     "is a rectified rig; the camera's raw views need a raw pair's calibration "
                     "(a `stereo_pair:` map, or the EuRoC cam0/cam1 sensor.yaml)");
  }
  throw InputError(path, "stereo_pair",
                   "is missing (expected Kestrel's `stereo_pair:` map of a raw pair)");
}

void CalibrationFilesField::read(const YAML::Node& node, std::vector<fs::path>& files) const {
  files.clear();
  if (node.IsSequence()) {
    for (const auto& f : node) files.emplace_back(f.as<std::string>());
  } else {
    files.emplace_back(node.as<std::string>());
  }
}

std::string CalibrationFilesField::text(const std::vector<fs::path>& files) const {
  YAML::Emitter out;
  out << YAML::Flow << YAML::BeginSeq;
  for (const auto& f : files) out << f.string();
  out << YAML::EndSeq;
  return out.c_str();
}

void CameraSourceOptions::load_files(const YAML::Node& block, const fs::path& config) {
  if (!decoder_options_file.empty()) {
    decoder_options_file = io::path_in_config(config, decoder_options_file);
    load_decoder_file(block, config, *this);
  }
  decoder.width = camera.width;
  decoder.height = camera.height;
  if (calibration_files.empty()) {
    throw camera_field_error(
        config, "calibration",
        "missing (the stereo calibration of the camera: Kestrel's stereo_pair YAML, "
        "an EuRoC folder, or [cam0 sensor.yaml, cam1 sensor.yaml])");
  }
  for (auto& f : calibration_files) f = io::path_in_config(config, f);
  try {
    calibration = load_camera_calibration(calibration_files);
  } catch (const InputError& e) {
    throw camera_field_error(config, "calibration", e.what());
  }
  validate(config);
}

void CameraSourceOptions::validate(const fs::path& config) const {
  if (device.empty()) throw camera_field_error(config, "device", "must name a video device node");
  try {
    camera.validate();
  } catch (const std::invalid_argument& e) {
    // The driver's messages name the field ("camera: buffers must be in 2..32").
    throw camera_field_error(config, "", e.what());
  }
  try {
    decoder.validate();
  } catch (const std::invalid_argument& e) {
    throw camera_field_error(config, "", e.what());
  }
  if (!(timeout_s > 0.0) || !(timeout_s <= 3600.0)) {
    throw camera_field_error(config, "timeout_s", "must be in (0, 3600] s");
  }
  if (!calibration) throw camera_field_error(config, "calibration", "missing");
  const int w = calibration->left.width(), h = calibration->left.height();
  if (w != camera.width || h != camera.height) {
    throw camera_field_error(config, "calibration",
                             "is for " + std::to_string(w) + "x" + std::to_string(h) +
                                 " images, the camera is asked for " +
                                 std::to_string(camera.width) + "x" +
                                 std::to_string(camera.height));
  }
}

std::string CameraSourceOptions::describe() const {
  std::ostringstream s;
  s << "device=" << device << " asked: " << camera.describe() << "; decoder: " << decoder.describe()
    << "; timeout " << timeout_s << " s; calibration:";
  for (const auto& f : calibration_files) s << " " << f.string();
  return s.str();
}

std::string CameraSourceOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

}  // namespace kestrel::pipeline
