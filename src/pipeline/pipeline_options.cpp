// Loading and checking the pipeline's config YAML.
#include "kestrel/pipeline/pipeline_options.hpp"

#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

// The keys of the other source are errors, not ignored.
void check_source_keys(const YAML::Node& root, const fs::path& path, const PipelineOptions& o) {
  if (o.source == Source::kFolder) {
    if (root["camera"]) {
      throw InputError(path, "camera", "is for source: camera (this config reads a folder)");
    }
    if (o.input.empty()) throw InputError(path, "input", "missing (the EuRoC folder to run on)");
    return;
  }
  if (!o.input.empty()) {
    throw InputError(path, "input", "is for source: folder (a camera source reads camera.device)");
  }
  if (root["pace"]) {
    throw InputError(path, "pace", "is for source: folder (a camera delivers at its own rate)");
  }
  if (!root["camera"]) {
    throw InputError(path, "camera",
                     "missing (source: camera needs a camera block with its calibration)");
  }
}

// Takes `file` from the config's folder; false when the config names none.
bool resolve(const fs::path& config, fs::path& file) {
  if (file.empty()) return false;
  file = io::path_in_config(config, file);
  return true;
}

// The files a config names, relative to its folder: the input, the option files, and those of
// the controller and camera blocks.
void load_named_files(const YAML::Node& root, const fs::path& path, PipelineOptions& o) {
  resolve(path, o.input);
  resolve(path, o.matcher_options_file);
  resolve(path, o.sgm_options_file);
  sensor::StereoFrontEndOptions front_end;
  sensor::apply_matcher_selection({o.matcher_kind, o.matcher_options_file, o.sgm_options_file},
                                  path.string(), front_end);
  o.matcher = front_end.matcher;
  o.sgm = front_end.sgm;
  if (resolve(path, o.tracker_options_file)) {
    if (root["tracker"]) {
      throw InputError(path, "tracker", "excludes tracker_options (give one or the other)");
    }
    o.tracker = odometry::DirectTrackerOptions::load(o.tracker_options_file,
                                                     odometry::stereo_head_tracker_options());
  }
  if (resolve(path, o.fusion_options_file)) {
    o.fusion = fusion::FusionOptions::load_yaml(o.fusion_options_file);
  }
  o.controller.load_files(path);
  if (o.source == Source::kCamera) o.camera.load_files(root["camera"], path);
}

}  // namespace

std::string_view to_string(Pace pace) { return pace == Pace::kFast ? "fast" : "recorded"; }

std::string_view to_string(Source source) {
  return source == Source::kFolder ? "folder" : "camera";
}

void parse_option(std::string_view name, Pace& pace) {
  if (name == "fast") {
    pace = Pace::kFast;
  } else if (name == "recorded") {
    pace = Pace::kRecorded;
  } else {
    throw std::invalid_argument("must be fast or recorded, got '" + std::string(name) + "'");
  }
}

void parse_option(std::string_view name, Source& source) {
  if (name == "folder") {
    source = Source::kFolder;
  } else if (name == "camera") {
    source = Source::kCamera;
  } else {
    throw std::invalid_argument("must be folder or camera, got '" + std::string(name) + "'");
  }
}

PipelineOptions PipelineOptions::load_yaml(const fs::path& path) {
  const YAML::Node root = io::load_yaml_map(path, "pipeline");
  PipelineOptions o;
  o.config_file = path;
  io::option_fields::read_fields(root, path.string(), "pipeline", o);
  check_source_keys(root, path, o);
  load_named_files(root, path, o);
  try {
    o.validate();
  } catch (const InputError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

void PipelineOptions::validate() const {
  if (source == Source::kCamera) camera.validate(config_file);
  const auto at_least_one = [](std::size_t n, const char* field) {
    if (n < 1) throw InputError(std::string("field '") + field + "': must be at least 1, got 0");
  };
  at_least_one(frame_queue_capacity, "frame_queue_capacity");
  at_least_one(fusion_queue_capacity, "fusion_queue_capacity");
  at_least_one(state_queue_capacity, "state_queue_capacity");
  if (!(vo_covariance_scale > 0.0)) {
    throw InputError("field 'vo_covariance_scale': must be positive");
  }
  if (output.empty()) throw InputError("field 'output': must name a file");
  tracker.validate();
  controller.validate();
  if (controller.output == output) {
    throw InputError("field 'controller.output': must differ from output");
  }
}

std::string PipelineOptions::describe() const {
  std::ostringstream s;
  if (source == Source::kCamera) {
    s << "source=camera (" << camera.describe() << ")";
  } else {
    s << "input=" << input.string() << " pace=" << to_string(pace);
  }
  s << " drop_stale=" << (drops() ? "true" : "false") << " queues frame=" << frame_queue_capacity
    << " fusion=" << fusion_queue_capacity << " state=" << state_queue_capacity
    << " max_frames=" << max_frames << " vo_covariance_scale=" << vo_covariance_scale
    << " vo_reference=" << fusion::odometry_reference_name(vo_reference)
    << " output=" << output.string() << "\n  controller: " << controller.describe();
  return s.str();
}

sensor::StereoFrontEndOptions PipelineOptions::front_end_options() const {
  sensor::StereoFrontEndOptions f;
  f.matcher = matcher;
  f.kind = matcher_kind;
  f.sgm = sgm;
  return f;
}

std::string PipelineOptions::describe_matcher() const {
  if (matcher_kind == sensor::StereoMatcherKind::kSgm) {
    sensor::SgmOptions s = sgm;  // the front end's range: the block matcher's
    s.min_disparity = matcher.min_disparity;
    s.max_disparity = matcher.max_disparity;
    return s.describe();
  }
  sensor::BlockMatcherOptions b = matcher;
  if (matcher_kind) {
    b.cost = *matcher_kind == sensor::StereoMatcherKind::kCensus ? sensor::MatchingCost::kCensus
                                                                 : sensor::MatchingCost::kSad;
  }
  return b.describe();
}

std::string PipelineOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

}  // namespace kestrel::pipeline
