// Sensor calibration YAMLs: cameras (Kestrel's YAML or EuRoC sensor.yaml), the IMU's EuRoC
// sensor.yaml, rectified stereo, and stereo calibrations; every loader on every input.
#include "fuzz_input.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/sensor/rectification.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("sensor.yaml");
  const auto& path = file.write(data, size);
  using kestrel::fuzz::expect_parsed_or_refused;
  expect_parsed_or_refused([&] { (void)kestrel::io::load_camera_file(path); });
  expect_parsed_or_refused([&] { (void)kestrel::io::load_imu_noise(path); });
  expect_parsed_or_refused([&] { (void)kestrel::io::load_rectified_stereo(path); });
  expect_parsed_or_refused([&] { (void)kestrel::sensor::load_stereo_calibration(path); });
  return 0;
}
