// Camera presets and files: TUM presets, Kestrel YAML round trip, EuRoC sensor.yaml.
#include <gtest/gtest.h>

#include <fstream>
#include <utility>

#include "kestrel/core/error.hpp"
#include "kestrel/io/camera_io.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

TEST(CameraPresets, TumValues) {
  const auto fr1 = camera_preset("fr1");
  ASSERT_TRUE(fr1);
  EXPECT_DOUBLE_EQ(fr1->fx(), 517.3);
  EXPECT_DOUBLE_EQ(fr1->cy(), 255.3);
  EXPECT_DOUBLE_EQ(fr1->distortion().k3, 1.1633);
  EXPECT_DOUBLE_EQ(camera_preset("fr2")->fx(), 520.9);
  EXPECT_FALSE(camera_preset("fr3")->has_distortion());
  EXPECT_DOUBLE_EQ(camera_preset("ros")->cx(), 319.5);
  EXPECT_FALSE(camera_preset("fr4"));
  EXPECT_THROW(load_camera("no-such-camera"), InputError);
}

// The camera of a TUM-layout folder where none is named: its camera.yaml, which wins over a
// freiburgN in its path; else the preset the path names; else nothing.
TEST(CameraForFolder, OwnFileThenTheNamesPreset) {
  const auto root = kestrel::test::fresh_temp_dir("camera_for_folder");
  const auto fr1 = root / "rgbd_dataset_freiburg1_x";
  const auto plain = root / "rendered";
  std::filesystem::create_directories(fr1);
  std::filesystem::create_directories(plain);
  EXPECT_EQ(camera_for_folder(fr1), "fr1");
  EXPECT_EQ(camera_for_folder(root / "rgbd_dataset_freiburg3_y"), "fr3");
  EXPECT_EQ(camera_for_folder(plain), "");
  EXPECT_EQ(camera_preset_in_path(root / "rgbd_dataset_freiburg2_desk.bag"), "fr2");
  save_camera_yaml(plain / "camera.yaml", PinholeCamera({100.0, 100.0, 49.5, 39.5, 100, 80}),
                   "test");
  save_camera_yaml(fr1 / "camera.yaml", PinholeCamera({100.0, 100.0, 49.5, 39.5, 100, 80}), "test");
  EXPECT_EQ(camera_for_folder(plain), (plain / "camera.yaml").string());
  EXPECT_EQ(camera_for_folder(fr1), (fr1 / "camera.yaml").string());
  EXPECT_EQ(load_camera(camera_for_folder(plain)).fx(), 100.0);
  std::filesystem::remove_all(root);
}

TEST(CameraYaml, RoundTripKeepsEveryValue) {
  const auto dir = test::fresh_temp_dir("io");
  const PinholeCamera cam({458.654, 457.296, 367.215, 248.375, 752, 480},
                          {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.001});
  save_camera_yaml(dir / "cam.yaml", cam, "test");
  const PinholeCamera back = load_camera((dir / "cam.yaml").string());
  EXPECT_DOUBLE_EQ(back.fx(), cam.fx());
  EXPECT_DOUBLE_EQ(back.cy(), cam.cy());
  EXPECT_EQ(back.width(), 752);
  EXPECT_DOUBLE_EQ(back.distortion().p2, cam.distortion().p2);
  EXPECT_DOUBLE_EQ(back.distortion().k3, 0.001);
  // Re-saving with another command is refused (the file says who wrote it).
  EXPECT_THROW(save_camera_yaml(dir / "cam.yaml", cam, "other"), InputError);

  const RectifiedStereo st{450.0, 370.0, 250.0, 0.11, 752, 480};
  save_rectified_stereo_yaml(dir / "stereo.yaml", st, "test");
  const RectifiedStereo st2 = load_rectified_stereo(dir / "stereo.yaml");
  EXPECT_DOUBLE_EQ(st2.baseline_m, 0.11);
  EXPECT_DOUBLE_EQ(st2.depth_from_disparity(10.0), 0.11 * 450.0 / 10.0);
}

TEST(CameraYaml, EurocWriterMatchesReader) {
  const auto dir = test::fresh_temp_dir("io");
  const PinholeCamera cam({400, 401, 320, 240, 640, 480}, {0.1, -0.01, 0.001, 0.002, 0});
  const SE3 T_BS = SE3::exp((Vector6d() << 0.1, 0.2, 0.3, 0.01, -0.02, 0.5).finished());
  save_euroc_camera_yaml(dir / "sensor.yaml", cam, T_BS, 20.0, "test");
  const CameraFile f = load_camera_file(dir / "sensor.yaml");
  EXPECT_DOUBLE_EQ(f.camera.fy(), 401);
  ASSERT_TRUE(f.T_body_sensor);
  EXPECT_LT((f.T_body_sensor->matrix() - T_BS.matrix()).norm(), 1e-9);
}

TEST(CameraYaml, MissingFieldIsNamed) {
  const auto dir = test::fresh_temp_dir("io");
  std::ofstream(dir / "bad.yaml") << "camera:\n  fx: 500\n  fy: 500\n  cx: 320\n  width: 640\n"
                                     "  height: 480\n";
  try {
    load_camera_file(dir / "bad.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.cy"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos);
  }
  std::ofstream(dir / "neg.yaml")
      << "camera: {fx: -1, fy: 500, cx: 1, cy: 1, width: 2, height: 2}\n";
  EXPECT_THROW(load_camera_file(dir / "neg.yaml"), InputError);
  std::ofstream(dir / "broken.yaml") << "camera: [1, 2\n";
  try {
    load_camera_file(dir / "broken.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.yaml:"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "other.yaml") << "foo: 1\n";
  EXPECT_THROW(load_camera_file(dir / "other.yaml"), InputError);
}

// The RGB-D sensor facts of Kestrel's camera map: depth scale and rolling-shutter readout.
TEST(CameraYaml, SensorFactsAreReadAndChecked) {
  const auto dir = test::fresh_temp_dir("io");
  const std::string pinhole =
      "camera:\n  width: 640\n  height: 480\n  fx: 525\n  fy: 525\n"
      "  cx: 319.5\n  cy: 239.5\n";
  std::ofstream(dir / "plain.yaml") << pinhole;
  const CameraFile plain = load_camera_file(dir / "plain.yaml");
  EXPECT_FALSE(plain.depth_scale);
  EXPECT_EQ(plain.rolling_shutter_readout_s, 0.0);
  EXPECT_EQ(plain.time_offset_s, 0.0);
  std::ofstream(dir / "rgbd.yaml") << pinhole
                                   << "  depth_scale: 1000\n  rolling_shutter_readout_s: 0.02\n"
                                      "  time_offset_s: -0.012\n";
  const CameraFile rgbd = load_camera_description((dir / "rgbd.yaml").string());
  EXPECT_EQ(rgbd.depth_scale, 1000.0);
  EXPECT_EQ(rgbd.rolling_shutter_readout_s, 0.02);
  EXPECT_EQ(rgbd.time_offset_s, -0.012);
  for (const char* preset : {"fr1", "fr2", "fr3", "ros"}) {
    const CameraFile p = load_camera_description(preset);
    EXPECT_EQ(p.depth_scale, 5000.0) << preset;
    EXPECT_EQ(p.rolling_shutter_readout_s, 0.0) << preset;
    EXPECT_EQ(p.time_offset_s, 0.0) << preset;
  }
  for (const auto& [line, field] :
       {std::pair{"  depth_scale: 0\n", "camera.depth_scale"},
        std::pair{"  depth_scale: many\n", "camera.depth_scale"},
        std::pair{"  rolling_shutter_readout_s: -0.01\n", "camera.rolling_shutter_readout_s"},
        std::pair{"  rolling_shutter_readout_s: .nan\n", "camera.rolling_shutter_readout_s"},
        std::pair{"  time_offset_s: 2\n", "camera.time_offset_s"},
        std::pair{"  time_offset_s: .nan\n", "camera.time_offset_s"},
        std::pair{"  time_offset_s: soon\n", "camera.time_offset_s"}}) {
    std::ofstream(dir / "bad.yaml") << pinhole << line;
    try {
      load_camera_file(dir / "bad.yaml");
      ADD_FAILURE() << line << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  }
}

// Found by the sensor_yaml fuzzer: a resolution beyond int's range was cast to int (undefined
// behaviour, UBSan: "4.22222e+49 is outside the range of representable values of type 'int'").
TEST(CameraYaml, EurocResolutionOutOfRangeIsAnInputError) {
  const auto dir = test::fresh_temp_dir("io");
  const std::string head =
      "sensor_type: camera\ncamera_model: pinhole\n"
      "intrinsics: [458.654, 457.296, 367.215, 248.375]\nresolution: ";
  for (const char* res : {"[752, 42222222222222222222222222222222222222222222222280]",
                          "[752, -480]", "[752.5, 480]", "[0, 480]", "[752, .nan]"}) {
    std::ofstream(dir / "sensor.yaml") << head << res << "\n";
    try {
      load_camera_file(dir / "sensor.yaml");
      ADD_FAILURE() << res << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("resolution"), std::string::npos) << e.what();
    }
  }
}

TEST(CameraYaml, RealEurocSensorFile) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/cam0/sensor.yaml");
  const auto f =
      load_camera_file(test::shared_data_dir() / "euroc/V1_01_easy_part1/mav0/cam0/sensor.yaml");
  EXPECT_DOUBLE_EQ(f.camera.fx(), 458.654);
  EXPECT_DOUBLE_EQ(f.camera.cy(), 248.375);
  EXPECT_EQ(f.camera.width(), 752);
  EXPECT_EQ(f.camera.height(), 480);
  EXPECT_DOUBLE_EQ(f.camera.distortion().k1, -0.28340811);
  ASSERT_TRUE(f.T_body_sensor);
  EXPECT_NEAR(f.T_body_sensor->translation().x(), -0.0216401454975, 1e-12);
}

}  // namespace
}  // namespace kestrel::io
