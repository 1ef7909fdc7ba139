// EuRoC reader on the real V1_01 part and on broken copies of its files.
#include <gtest/gtest.h>

#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {
namespace fs = std::filesystem;

TEST(Euroc, RealV101StereoImuAndCalibration) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/cam0/data.csv");
  const EurocSequence seq(test::shared_data_dir() / "euroc/V1_01_easy_part1");
  EXPECT_EQ(seq.stereo_size(), 60u);
  const StereoImages s = seq.load_stereo(0);
  EXPECT_EQ(s.left.size(), cv::Size(752, 480));
  EXPECT_EQ(s.left.type(), CV_8UC1);
  EXPECT_EQ(s.right.size(), s.left.size());
  EXPECT_EQ(s.t_ns, 1403715273262142976LL);
  const auto cam1 = seq.cam1_calibration();
  ASSERT_TRUE(cam1.T_body_sensor);
  const auto cam0 = seq.cam0_calibration();
  // The EuRoC rig's baseline is about 11 cm.
  const double baseline =
      (cam0.T_body_sensor->inverse() * *cam1.T_body_sensor).translation().norm();
  EXPECT_NEAR(baseline, 0.110, 0.002);

  ASSERT_TRUE(seq.has_imu());
  const ImuNoise noise = seq.imu_noise();
  EXPECT_DOUBLE_EQ(noise.gyro_noise_density, 1.6968e-04);
  EXPECT_DOUBLE_EQ(noise.accel_random_walk, 3.0e-3);
  EXPECT_DOUBLE_EQ(noise.rate_hz, 200);
  ImuCsvReader imu(seq.imu_csv());
  ImuSample sample;
  std::size_t n = 0;
  TimeNs first = 0, last = 0;
  Eigen::Vector3d mean_accel = Eigen::Vector3d::Zero();
  while (imu.next(sample)) {
    if (n == 0) first = sample.t_ns;
    last = sample.t_ns;
    mean_accel += sample.accel_m_s2;
    ++n;
  }
  // ~145 s at 200 Hz; the mean specific force is gravity's magnitude.
  EXPECT_NEAR(ns_to_s(last - first) * 200.0, static_cast<double>(n - 1), 5.0);
  EXPECT_NEAR((mean_accel / static_cast<double>(n)).norm(), 9.81, 0.3);
  const auto gt = seq.groundtruth_csv();
  ASSERT_TRUE(gt);
  EXPECT_EQ(gt->parent_path().filename(), "groundtruth_cam0");
}

TEST(Euroc, StateGroundTruthOfV102) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const auto states = read_euroc_state_groundtruth(
      test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  ASSERT_GT(states.size(), 1000u);
  EXPECT_NEAR(states[0].T_world_body.translation().x(), 0.515292, 1e-9);
  EXPECT_NEAR(states[0].gyro_bias.z(), 0.075806, 1e-9);
  EXPECT_NEAR(states[0].accel_bias.x(), -0.013337, 1e-9);
}

TEST(Euroc, BadImuLinesNameFileAndLine) {
  const auto dir = test::fresh_temp_dir("euroc");
  const auto csv = dir / "data.csv";
  const auto error_of = [&](const std::string& body) -> std::string {
    std::ofstream(csv) << "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n" << body;
    try {
      ImuCsvReader r(csv);
      ImuSample s;
      while (r.next(s)) {
      }
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of("1,0,0,0,0,0,9.8\n2,0,0,0,0,0,9.8\n"), "");
  EXPECT_NE(error_of("1,0,0,0,0,0,9.8\n2,0,0,nan,0,0,9.8\n").find("data.csv:3:"),
            std::string::npos);
  EXPECT_NE(error_of("1,0,0,0,0,0\n").find("expected 7"), std::string::npos);
  EXPECT_NE(error_of("2,0,0,0,0,0,9.8\n1,0,0,0,0,0,9.8\n").find("does not increase"),
            std::string::npos);
  EXPECT_NE(error_of("x,0,0,0,0,0,9.8\n").find("data.csv:2:"), std::string::npos);
}

TEST(Euroc, MissingImuFieldIsNamed) {
  const auto dir = test::fresh_temp_dir("euroc");
  std::ofstream(dir / "sensor.yaml") << "%YAML:1.0\ngyroscope_noise_density: 1e-4\n"
                                        "gyroscope_random_walk: 1e-5\n"
                                        "accelerometer_noise_density: 2e-3\nrate_hz: 200\n";
  try {
    load_imu_noise(dir / "sensor.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("accelerometer_random_walk"), std::string::npos);
  }
}

TEST(Euroc, ImuSensorFileThatIsNotAMapIsAnInputError) {
  // Found by fuzz/sensor_yaml.cpp: a scalar document (here with NUL bytes, after the OpenCV
  // directive) made yaml-cpp's BadSubscript escape, a message that names no file.
  const auto dir = test::fresh_temp_dir("euroc");
  const std::string crash("%YA\0\0\0\0\0\0\0\0\0\0\0ML:1.0\ncommenc FireAV\n", 36);
  for (const std::string& text :
       {crash, std::string("%YAML:1.0\njust a scalar\n"), std::string("- 1\n- 2\n")}) {
    std::ofstream(dir / "sensor.yaml", std::ios::binary) << text;
    try {
      load_imu_noise(dir / "sensor.yaml");
      ADD_FAILURE() << "loaded: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("sensor.yaml"), std::string::npos) << e.what();
    }
  }
}

TEST(Euroc, NotAnEurocFolder) {
  const auto dir = test::fresh_temp_dir("euroc");
  EXPECT_THROW(EurocSequence seq(dir), InputError);
}

}  // namespace
}  // namespace kestrel::io
