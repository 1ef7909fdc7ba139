// The `camera:` block of a pipeline config (source: camera): every field read, defaults, the
// three calibration forms, and errors that name the config file and the field.
#include <gtest/gtest.h>

#include <string>

#include "camera_test_files.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "test_data.hpp"

namespace kestrel::pipeline {
namespace {

namespace fs = std::filesystem;
using test::write_text;

class CameraSourceConfig : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("camera_config");
    test::write_pinhole_pair(dir_ / "calib.yaml", 752, 480);
  }
  void TearDown() override { fs::remove_all(dir_); }
  /// "source: camera" and a camera block with the calibration plus `camera_lines`, then `rest`.
  fs::path config(const std::string& camera_lines, const std::string& rest = "",
                  const std::string& name = "run.yaml") const {
    return write_text(dir_ / name,
                      "source: camera\ncamera:\n  calibration: calib.yaml\n" + camera_lines + rest);
  }
  /// The error of a config, checked to name the file and `field` (quoted as the errors do).
  void expect_error(const fs::path& file, const std::string& field,
                    const std::string& also = "") const {
    const std::string e = test::config_error_of(file);
    ASSERT_FALSE(e.empty()) << "no error for " << field;
    EXPECT_NE(e.find(file.string()), std::string::npos) << e;
    EXPECT_NE(e.find("field '" + field + "'"), std::string::npos) << e;
    if (!also.empty()) {
      EXPECT_NE(e.find(also), std::string::npos) << e;
    }
  }

  fs::path dir_;
};

TEST_F(CameraSourceConfig, ReadsEveryField) {
  const PipelineOptions o = PipelineOptions::load_yaml(
      config("  device: /dev/video3\n  pixel_format: Y8I\n  width: 752\n  height: 480\n"
             "  fps: 60\n  buffers: 6\n  timeout_s: 0.5\n  left_byte: 1\n  bayer: RGGB\n"
             "  demosaic: edge-aware\n",
             "max_frames: 100\n"));
  EXPECT_EQ(o.source, Source::kCamera);
  const CameraSourceOptions& c = o.camera;
  EXPECT_EQ(c.device, "/dev/video3");
  EXPECT_EQ(c.camera.pixel_format, "Y8I");
  EXPECT_EQ(c.camera.width, 752);
  EXPECT_EQ(c.camera.height, 480);
  EXPECT_DOUBLE_EQ(c.camera.rate_hz, 60.0);
  EXPECT_EQ(c.camera.buffers, 6);
  EXPECT_DOUBLE_EQ(c.timeout_s, 0.5);
  EXPECT_EQ(c.decoder.left_byte, 1);
  EXPECT_EQ(c.decoder.phase, driver::BayerPhase::kRGGB);
  EXPECT_EQ(c.decoder.demosaic, driver::DemosaicMethod::kEdgeAware);
  EXPECT_EQ(c.decoder.width, 752);  // the decoder's size is the camera's
  EXPECT_EQ(c.decoder.height, 480);
  ASSERT_EQ(c.calibration_files.size(), 1u);
  EXPECT_EQ(c.calibration_files[0], dir_ / "calib.yaml");  // relative to the config
  ASSERT_TRUE(c.calibration.has_value());
  EXPECT_NEAR(c.calibration->T_left_right.translation().x(), 0.1, 1e-12);
  EXPECT_EQ(o.max_frames, 100u);
  EXPECT_NE(o.describe().find("/dev/video3"), std::string::npos) << o.describe();
}

TEST_F(CameraSourceConfig, DefaultsAreThoseOfKestrelCapture) {
  const PipelineOptions o = PipelineOptions::load_yaml(config(""));
  EXPECT_EQ(o.camera.device, "/dev/video0");
  EXPECT_EQ(o.camera.camera.pixel_format, "YUYV");
  EXPECT_EQ(o.camera.camera.width, 752);
  EXPECT_EQ(o.camera.camera.height, 480);
  EXPECT_DOUBLE_EQ(o.camera.camera.rate_hz, 0.0);
  EXPECT_EQ(o.camera.decoder.left_byte, 0);
  EXPECT_EQ(o.camera.decoder.phase, driver::BayerPhase::kGRBG);
  EXPECT_DOUBLE_EQ(o.camera.timeout_s, 2.0);
  EXPECT_TRUE(o.drops());  // a live camera drops stale frames unless told otherwise
  EXPECT_FALSE(PipelineOptions::load_yaml(config("", "drop_stale: false\n")).drops());
}

TEST_F(CameraSourceConfig, TheFolderSourceIsStillTheDefault) {
  const PipelineOptions o = PipelineOptions::load_yaml(write_text(dir_ / "f.yaml", "input: seq\n"));
  EXPECT_EQ(o.source, Source::kFolder);
  EXPECT_FALSE(o.drops());
  EXPECT_EQ(PipelineOptions::load_yaml(write_text(dir_ / "g.yaml", "source: folder\ninput: seq\n"))
                .source,
            Source::kFolder);
}

TEST_F(CameraSourceConfig, DecoderOptionsFileGivesTheDecoderAndTheSize) {
  test::write_pinhole_pair(dir_ / "small.yaml", 376, 240);
  write_text(dir_ / "decoder.yaml", "width: 376\nheight: 240\nleft_byte: 1\nbayer: BGGR\n");
  const PipelineOptions o = PipelineOptions::load_yaml(write_text(
      dir_ / "d.yaml",
      "source: camera\ncamera:\n  calibration: small.yaml\n  decoder_options: decoder.yaml\n"));
  EXPECT_EQ(o.camera.camera.width, 376);
  EXPECT_EQ(o.camera.camera.height, 240);
  EXPECT_EQ(o.camera.decoder.left_byte, 1);
  EXPECT_EQ(o.camera.decoder.phase, driver::BayerPhase::kBGGR);

  expect_error(write_text(dir_ / "e.yaml",
                          "source: camera\ncamera:\n  calibration: small.yaml\n"
                          "  decoder_options: decoder.yaml\n  left_byte: 0\n"),
               "camera.decoder_options", "left_byte");
  expect_error(write_text(dir_ / "f.yaml",
                          "source: camera\ncamera:\n  calibration: small.yaml\n"
                          "  decoder_options: decoder.yaml\n  width: 752\n"),
               "camera.decoder_options", "376x240");
}

TEST_F(CameraSourceConfig, BadFieldsNameTheFileAndField) {
  expect_error(write_text(dir_ / "a.yaml", "source: webcam\n"), "source", "'webcam'");
  expect_error(config("  exposure: 3\n", "", "b.yaml"), "camera.exposure",
               "is not a pipeline option");
  expect_error(config("  bayer: XYZW\n", "", "c.yaml"), "camera.bayer", "'XYZW'");
  expect_error(config("  demosaic: nearest\n", "", "d.yaml"), "camera.demosaic", "'nearest'");
  expect_error(config("  width: wide\n", "", "e.yaml"), "camera.width", "wrong type");
  expect_error(config("  buffers: 1\n", "", "f.yaml"), "camera", "buffers");
  expect_error(config("  left_byte: 2\n", "", "g.yaml"), "camera", "left_byte");
  expect_error(config("  pixel_format: TOOLONG\n", "", "h.yaml"), "camera", "pixel_format");
  expect_error(config("  timeout_s: 0\n", "", "i.yaml"), "camera.timeout_s");
  expect_error(config("  fps: -5\n", "", "j.yaml"), "camera", "rate");
  expect_error(config("  device: ''\n", "", "k.yaml"), "camera.device");
  // The keys of the other source.
  expect_error(config("", "input: seq\n", "l.yaml"), "input", "source: folder");
  expect_error(config("", "pace: recorded\n", "m.yaml"), "pace", "source: folder");
  expect_error(write_text(dir_ / "n.yaml", "input: seq\ncamera:\n  device: /dev/video0\n"),
               "camera", "source: camera");
  expect_error(write_text(dir_ / "o.yaml", "source: camera\n"), "camera", "missing");
}

TEST_F(CameraSourceConfig, TheCalibrationIsRequiredAndChecked) {
  expect_error(write_text(dir_ / "a.yaml", "source: camera\ncamera:\n  device: /dev/video0\n"),
               "camera.calibration", "missing");
  expect_error(write_text(dir_ / "b.yaml", "source: camera\ncamera:\n  calibration: nope.yaml\n"),
               "camera.calibration", (dir_ / "nope.yaml").string());
  // Another size than the camera is asked for.
  expect_error(config("  width: 640\n", "", "c.yaml"), "camera.calibration", "752x480");
  // A rectified rig cannot rectify raw views.
  write_text(dir_ / "rig.yaml",
             "stereo: {f: 300, cu: 376, cv: 240, baseline_m: 0.1, width: 752, height: 480}\n");
  expect_error(write_text(dir_ / "d.yaml", "source: camera\ncamera:\n  calibration: rig.yaml\n"),
               "camera.calibration", "rectified");
  // The loader's own error (its file and field) is kept inside.
  write_text(dir_ / "broken.yaml", "stereo_pair:\n  left: {width: 752}\n");
  expect_error(write_text(dir_ / "e.yaml", "source: camera\ncamera:\n  calibration: broken.yaml\n"),
               "camera.calibration", "broken.yaml");
  // Two files are an EuRoC sensor.yaml pair.
  expect_error(
      write_text(dir_ / "f.yaml", "source: camera\ncamera:\n  calibration: [x0.yaml, x1.yaml]\n"),
      "camera.calibration", "x0.yaml");
}

TEST_F(CameraSourceConfig, EurocFolderAndSensorYamlPairAreCalibrations) {
  const fs::path seq = test::shared_data_dir() / "euroc/V1_01_easy_part1";
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const PipelineOptions folder = PipelineOptions::load_yaml(write_text(
      dir_ / "a.yaml", "source: camera\ncamera:\n  calibration: " + seq.string() + "\n"));
  const fs::path cam0 = seq / "mav0/cam0/sensor.yaml", cam1 = seq / "mav0/cam1/sensor.yaml";
  const PipelineOptions pair = PipelineOptions::load_yaml(write_text(
      dir_ / "b.yaml",
      "source: camera\ncamera:\n  calibration: [" + cam0.string() + ", " + cam1.string() + "]\n"));
  ASSERT_TRUE(folder.camera.calibration && pair.camera.calibration);
  // EuRoC's stereo baseline is about 11 cm; both forms read the same files.
  const double b = folder.camera.calibration->T_left_right.translation().norm();
  EXPECT_NEAR(b, 0.11, 0.01);
  EXPECT_DOUBLE_EQ(pair.camera.calibration->T_left_right.translation().norm(), b);
  EXPECT_EQ(folder.camera.calibration->left.width(), 752);
}

}  // namespace
}  // namespace kestrel::pipeline
