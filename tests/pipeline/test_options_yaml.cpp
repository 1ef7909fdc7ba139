// The pipeline config through the options table: printed defaults (camera and controller blocks,
// inline tracker) load back to the same text, the shipped configs load, and a bad key is an
// error naming the config file and the nested field.
#include <gtest/gtest.h>

#include <string>

#include "camera_test_files.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "test_data.hpp"

namespace kestrel::pipeline {
namespace {

namespace fs = std::filesystem;

const fs::path kShippedConfigs = fs::path(KESTREL_SOURCE_DIR) / "config";

template <typename Options>
std::string read_back(const Options& o, const char* what) {
  Options back;
  io::option_fields::read_fields(YAML::Load(o.to_yaml()), "back.yaml", what, back);
  return back.to_yaml();
}

TEST(PipelineOptionsYaml, DefaultsRoundTrip) {
  const PipelineOptions defaults;
  const std::string yaml = defaults.to_yaml();
  EXPECT_NE(yaml.find("source: folder\ninput: \"\"\ncamera:\n  device: /dev/video0\n"),
            std::string::npos)
      << yaml;
  EXPECT_NE(yaml.find("\ncontroller:\n  setpoint: hold\n"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("drop_stale"), std::string::npos) << yaml;  // unset: by pace and source
  EXPECT_EQ(read_back(defaults, "pipeline"), yaml);
}

TEST(PipelineOptionsYaml, ChangedBlocksRoundTrip) {
  CameraSourceOptions camera;
  camera.device = "/dev/video2";
  camera.decoder.phase = driver::BayerPhase::kRGGB;
  camera.calibration_files = {"cam0 sensor.yaml", "cam1/sensor.yaml"};
  EXPECT_NE(camera.to_yaml().find("calibration: [cam0 sensor.yaml, cam1/sensor.yaml]\n"),
            std::string::npos)
      << camera.to_yaml();
  EXPECT_EQ(read_back(camera, "camera source"), camera.to_yaml());

  ControllerStageOptions controller;
  controller.setpoint = Eigen::Vector4d(1.0, -2.0, 3.5, 0.0);
  controller.R_body_vehicle = parse_vehicle_axes({"+z", "-y", "+x"});
  controller.allow_unfused = true;
  EXPECT_NE(controller.to_yaml().find("setpoint: [1, -2, 3.5, 0]\n"), std::string::npos)
      << controller.to_yaml();
  EXPECT_NE(controller.to_yaml().find("vehicle_axes: [+z, -y, +x]\n"), std::string::npos)
      << controller.to_yaml();
  EXPECT_EQ(read_back(controller, "controller"), controller.to_yaml());

  PipelineOptions o;
  o.drop_stale = false;
  o.pace = Pace::kRecorded;
  o.vo_reference = fusion::OdometryReference::kPreviousFrame;
  o.tracker.pyramid.levels = 3;
  EXPECT_NE(o.to_yaml().find("drop_stale: false\n"), std::string::npos) << o.to_yaml();
  EXPECT_EQ(read_back(o, "pipeline"), o.to_yaml());
}

TEST(PipelineOptionsYaml, UnknownKeysNameTheFileAndTheNestedField) {
  const fs::path dir = test::fresh_temp_dir("pipeline_options_yaml");
  const fs::path a = test::write_text(dir / "a.yaml", "input: x\ncontroller:\n  set_point: hold\n");
  EXPECT_EQ(test::config_error_of(a),
            a.string() + ": field 'controller.set_point': is not a pipeline option");
  const fs::path b = test::write_text(dir / "b.yaml", "input: x\nouptut: t.txt\n");
  EXPECT_EQ(test::config_error_of(b), b.string() + ": field 'ouptut': is not a pipeline option");
  const fs::path c = test::write_text(dir / "c.yaml", "");
  EXPECT_EQ(test::config_error_of(c), c.string() + ": expected a YAML map of pipeline options");
  fs::remove_all(dir);
}

TEST(PipelineOptionsYaml, InlineTrackerAndTrackerFileExcludeEachOther) {
  const fs::path dir = test::fresh_temp_dir("pipeline_options_yaml");
  test::write_text(dir / "t.yaml", "tracker:\n  pyramid:\n    levels: 4\n");
  const PipelineOptions file = PipelineOptions::load_yaml(
      test::write_text(dir / "a.yaml", "input: x\ntracker_options: t.yaml\n"));
  EXPECT_EQ(file.tracker.pyramid.levels, 4);
  EXPECT_EQ(file.tracker_options_file, dir / "t.yaml");
  const PipelineOptions inline_map = PipelineOptions::load_yaml(
      test::write_text(dir / "b.yaml", "input: x\ntracker:\n  pyramid:\n    levels: 2\n"));
  EXPECT_EQ(inline_map.tracker.pyramid.levels, 2);
  // Both read over the stereo head's defaults: what they leave out keeps no far depth limit.
  const double no_limit = odometry::stereo_head_tracker_options().selection.max_depth_m;
  EXPECT_EQ(PipelineOptions().tracker.selection.max_depth_m, no_limit);
  EXPECT_EQ(file.tracker.selection.max_depth_m, no_limit);
  EXPECT_EQ(inline_map.tracker.selection.max_depth_m, no_limit);
  const fs::path both = test::write_text(
      dir / "c.yaml", "input: x\ntracker_options: t.yaml\ntracker:\n  pyramid: {levels: 2}\n");
  EXPECT_NE(test::config_error_of(both).find("field 'tracker': excludes tracker_options"),
            std::string::npos)
      << test::config_error_of(both);
  const fs::path bad =
      test::write_text(dir / "d.yaml", "input: x\ntracker:\n  pyramid: {levels: 0}\n");
  EXPECT_NE(test::config_error_of(bad).find("pyramid.levels"), std::string::npos)
      << test::config_error_of(bad);
  // The flat keys of earlier versions are unknown keys, named with their map.
  const fs::path flat =
      test::write_text(dir / "e.yaml", "input: x\ntracker:\n  pyramid_levels: 4\n");
  EXPECT_EQ(test::config_error_of(flat),
            flat.string() + ": field 'tracker.pyramid_levels': is not a pipeline option");
  fs::remove_all(dir);
}

TEST(ShippedConfig, PipelineEurocLoads) {
  const PipelineOptions o = PipelineOptions::load_yaml(kShippedConfigs / "pipeline_euroc.yaml");
  EXPECT_EQ(o.source, Source::kFolder);
  EXPECT_EQ(o.input, kShippedConfigs / "../../shared/data/euroc/V1_01_easy_part1");
  EXPECT_EQ(VehicleAxesField{}.text(o.controller.R_body_vehicle), "[+z, -y, +x]");
  EXPECT_FALSE(o.controller.setpoint.has_value());
}

TEST(ShippedConfig, PipelineCameraLoadsBesideItsCalibration) {
  // The camera config names its calibration beside it; the user writes that one.
  const fs::path dir = test::fresh_temp_dir("pipeline_options_yaml");
  fs::copy_file(kShippedConfigs / "pipeline_camera.yaml", dir / "pipeline_camera.yaml");
  test::write_pinhole_pair(dir / "camera_stereo.yaml", 752, 480);
  const PipelineOptions o = PipelineOptions::load_yaml(dir / "pipeline_camera.yaml");
  EXPECT_EQ(o.source, Source::kCamera);
  EXPECT_EQ(o.camera.device, "/dev/video0");
  EXPECT_TRUE(o.camera.calibration.has_value());
  EXPECT_EQ(VehicleAxesField{}.text(o.controller.R_body_vehicle), "[+z, -x, -y]");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::pipeline
