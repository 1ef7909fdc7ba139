// Loading and checking the `camera:` block of a pipeline config, and the stereo calibration it
// names (through the sensor module's loaders: no parser of its own).
#include "kestrel/pipeline/camera_source_options.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "config_fields.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/driver/bayer.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

using detail::path_in_config;

// Field `camera.<key>` (an empty key names the block itself).
InputError camera_field_error(const fs::path& config, const std::string& key,
                              const std::string& msg) {
  return detail::config_field_error(config, key.empty() ? "camera" : "camera." + key, msg);
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

CameraSourceOptions CameraSourceOptions::from_yaml(const YAML::Node& map, const fs::path& config) {
  if (!map.IsMap()) throw InputError(config, "camera", "must be a map of camera source options");
  CameraSourceOptions o;
  std::optional<fs::path> decoder_file;
  std::vector<std::string> decoder_keys;  // inline decoder options, exclusive with the file
  bool have_calibration = false, have_width = false, have_height = false;
  for (const auto& kv : map) {
    const auto key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    try {
      if (key == "device") {
        o.device = v.as<std::string>();
        if (o.device.empty())
          throw camera_field_error(config, key, "must name a video device node");
      } else if (key == "pixel_format") {
        o.camera.pixel_format = v.as<std::string>();
      } else if (key == "width") {
        o.camera.width = v.as<int>();
        have_width = true;
      } else if (key == "height") {
        o.camera.height = v.as<int>();
        have_height = true;
      } else if (key == "fps") {
        o.camera.rate_hz = v.as<double>();
      } else if (key == "buffers") {
        o.camera.buffers = v.as<int>();
      } else if (key == "timeout_s") {
        o.timeout_s = v.as<double>();
      } else if (key == "left_byte") {
        o.decoder.left_byte = v.as<int>();
        decoder_keys.push_back(key);
      } else if (key == "bayer") {
        const auto s = v.as<std::string>();
        const auto phase = driver::parse_bayer_phase(s);
        if (!phase)
          throw camera_field_error(config, key,
                                   "must be GRBG, RGGB, BGGR or GBRG, got '" + s + "'");
        o.decoder.phase = *phase;
        decoder_keys.push_back(key);
      } else if (key == "demosaic") {
        const auto s = v.as<std::string>();
        const auto method = driver::parse_demosaic_method(s);
        if (!method)
          throw camera_field_error(config, key, "must be bilinear or edge-aware, got '" + s + "'");
        o.decoder.demosaic = *method;
        decoder_keys.push_back(key);
      } else if (key == "decoder_options") {
        decoder_file = path_in_config(config, v.as<std::string>());
      } else if (key == "calibration") {
        if (v.IsSequence()) {
          for (const auto& f : v)
            o.calibration_files.push_back(path_in_config(config, f.as<std::string>()));
        } else {
          o.calibration_files.push_back(path_in_config(config, v.as<std::string>()));
        }
        have_calibration = true;
      } else {
        throw camera_field_error(config, key, "unknown camera source option");
      }
    } catch (const YAML::Exception&) {
      throw camera_field_error(config, key, "has the wrong type");
    }
  }
  if (decoder_file) {
    if (!decoder_keys.empty()) {
      throw camera_field_error(
          config, "decoder_options",
          "excludes camera." + decoder_keys.front() + " (give one or the other)");
    }
    o.decoder = driver::StereoDecoderOptions::load_yaml(*decoder_file);
    // The file may carry the size (it is the frame's); the camera block's wins only if it agrees.
    if ((have_width && o.camera.width != o.decoder.width) ||
        (have_height && o.camera.height != o.decoder.height)) {
      throw camera_field_error(
          config, "decoder_options",
          decoder_file->string() + " is for " + std::to_string(o.decoder.width) + "x" +
              std::to_string(o.decoder.height) + " frames, camera.width/height say " +
              std::to_string(o.camera.width) + "x" + std::to_string(o.camera.height));
    }
    o.camera.width = o.decoder.width;
    o.camera.height = o.decoder.height;
  }
  o.decoder.width = o.camera.width;
  o.decoder.height = o.camera.height;
  if (!have_calibration) {
    throw camera_field_error(
        config, "calibration",
        "missing (the stereo calibration of the camera: Kestrel's stereo_pair YAML, "
        "an EuRoC folder, or [cam0 sensor.yaml, cam1 sensor.yaml])");
  }
  try {
    o.calibration = load_camera_calibration(o.calibration_files);
  } catch (const InputError& e) {
    throw camera_field_error(config, "calibration", e.what());
  }
  o.validate(config);
  return o;
}

void CameraSourceOptions::validate(const fs::path& config) const {
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

}  // namespace kestrel::pipeline
