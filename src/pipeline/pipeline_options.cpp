// Loading and checking the pipeline's config YAML.
#include "kestrel/pipeline/pipeline_options.hpp"

#include <optional>
#include <sstream>

#include "config_fields.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

fs::path config_path(const fs::path& config, const YAML::Node& value) {
  return detail::path_in_config(config, value.as<std::string>());
}

std::size_t positive_size(const fs::path& config, const std::string& key, const YAML::Node& v) {
  const long long n = v.as<long long>();
  if (n < 1) throw InputError(config, key, "must be at least 1, got " + std::to_string(n));
  return static_cast<std::size_t>(n);
}

}  // namespace

PipelineOptions PipelineOptions::load_yaml(const fs::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (!root.IsMap()) throw InputError(path.string() + ": expected a YAML map of pipeline options");
  PipelineOptions o;
  o.config_file = path;
  bool have_input = false, have_pace = false;
  std::optional<YAML::Node> camera;  // parsed after the loop, once `source` is known
  for (const auto& kv : root) {
    const auto key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    try {
      if (key == "source") {
        const auto s = v.as<std::string>();
        if (s == "folder")
          o.source = Source::kFolder;
        else if (s == "camera")
          o.source = Source::kCamera;
        else
          throw InputError(path, key, "must be folder or camera, got '" + s + "'");
      } else if (key == "camera") {
        camera = v;
      } else if (key == "input") {
        o.input = config_path(path, v);
        have_input = true;
      } else if (key == "pace") {
        have_pace = true;
        const auto s = v.as<std::string>();
        if (s == "fast")
          o.pace = Pace::kFast;
        else if (s == "recorded")
          o.pace = Pace::kRecorded;
        else
          throw InputError(path, key, "must be fast or recorded, got '" + s + "'");
      } else if (key == "drop_stale") {
        o.drop_stale = v.as<bool>();
      } else if (key == "frame_queue_capacity") {
        o.frame_queue_capacity = positive_size(path, key, v);
      } else if (key == "fusion_queue_capacity") {
        o.fusion_queue_capacity = positive_size(path, key, v);
      } else if (key == "state_queue_capacity") {
        o.state_queue_capacity = positive_size(path, key, v);
      } else if (key == "max_frames") {
        const long long n = v.as<long long>();
        if (n < 0) throw InputError(path, key, "must be 0 (all) or positive");
        o.max_frames = static_cast<std::size_t>(n);
      } else if (key == "vo_covariance_scale") {
        o.vo_covariance_scale = v.as<double>();
        if (!(o.vo_covariance_scale > 0.0)) throw InputError(path, key, "must be positive");
      } else if (key == "vo_reference") {
        try {
          o.vo_reference = fusion::parse_odometry_reference(v.as<std::string>());
        } catch (const std::invalid_argument& e) {
          throw InputError(path, key, e.what());
        }
      } else if (key == "output") {
        o.output = v.as<std::string>();
      } else if (key == "matcher_options") {
        o.matcher = sensor::BlockMatcherOptions::load_yaml(config_path(path, v));
      } else if (key == "tracker_options") {
        o.tracker = odometry::DirectTrackerOptions::load(config_path(path, v));
      } else if (key == "tracker") {
        o.tracker = odometry::DirectTrackerOptions::from_yaml(v, path.string() + ": tracker");
      } else if (key == "controller") {
        o.controller = ControllerStageOptions::from_yaml(v, path);
      } else if (key == "fusion_options") {
        o.fusion = fusion::FusionOptions::load_yaml(config_path(path, v));
      } else {
        throw InputError(path, key, "unknown pipeline option");
      }
    } catch (const YAML::Exception&) {
      throw InputError(path, key, "has the wrong type");
    }
  }
  if (o.source == Source::kFolder) {
    if (camera)
      throw InputError(path, "camera", "is for source: camera (this config reads a folder)");
    if (!have_input) throw InputError(path, "input", "missing (the EuRoC folder to run on)");
  } else {
    if (have_input) {
      throw InputError(path, "input",
                       "is for source: folder (a camera source reads camera.device)");
    }
    if (have_pace) {
      throw InputError(path, "pace", "is for source: folder (a camera delivers at its own rate)");
    }
    if (!camera) {
      throw InputError(path, "camera",
                       "missing (source: camera needs a camera block with its calibration)");
    }
    o.camera = CameraSourceOptions::from_yaml(*camera, path);
  }
  try {
    o.validate();
  } catch (const InputError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

void PipelineOptions::validate() const {
  if (source == Source::kCamera) camera.validate(config_file);
  if (frame_queue_capacity < 1 || fusion_queue_capacity < 1 || state_queue_capacity < 1) {
    throw InputError("queue capacities must be at least 1");
  }
  if (!(vo_covariance_scale > 0.0)) throw InputError("vo_covariance_scale must be positive");
  if (output.empty()) throw InputError("output must name a file");
  controller.validate();
  if (controller.output == output) throw InputError("controller.output must differ from output");
}

std::string PipelineOptions::describe() const {
  std::ostringstream s;
  if (source == Source::kCamera) {
    s << "source=camera (" << camera.describe() << ")";
  } else {
    s << "input=" << input.string() << " pace=" << (pace == Pace::kFast ? "fast" : "recorded");
  }
  s << " drop_stale=" << (drops() ? "true" : "false") << " queues frame=" << frame_queue_capacity
    << " fusion=" << fusion_queue_capacity << " state=" << state_queue_capacity
    << " max_frames=" << max_frames << " vo_covariance_scale=" << vo_covariance_scale
    << " vo_reference=" << fusion::odometry_reference_name(vo_reference)
    << " output=" << output.string() << "\n  controller: " << controller.describe();
  return s.str();
}

}  // namespace kestrel::pipeline
