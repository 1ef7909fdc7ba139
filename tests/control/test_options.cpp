// Options: the shipped YAMLs load and equal the documented defaults; print -> load round
// trips; typos and bad values are errors naming the file and field.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/sim/flight_controller_model.hpp"
#include "kestrel/sim/quadrotor.hpp"
#include "kestrel/sim/vehicle_imu.hpp"
#include "test_data.hpp"

namespace kestrel {
namespace {

const std::filesystem::path kConfig = std::filesystem::path(KESTREL_SOURCE_DIR) / "config";

template <typename Options>
void expect_same(const Options& a, const Options& b) {
  EXPECT_EQ(a.to_yaml(), b.to_yaml());
}

TEST(ShippedConfig, VehicleYamlEqualsTheDefaults) {
  expect_same(sim::QuadrotorParameters::load(kConfig / "vehicle_default.yaml"),
              sim::QuadrotorParameters{});
  expect_same(sim::FlightControllerModelOptions::load(kConfig / "vehicle_default.yaml"),
              sim::FlightControllerModelOptions{});
}

TEST(ShippedConfig, ControllerYamlEqualsTheDefaults) {
  const auto file = kConfig / "controller_default.yaml";
  expect_same(control::PositionControllerOptions::load(file), control::PositionControllerOptions{});
  expect_same(control::PwmMapperOptions::load(file), control::PwmMapperOptions{});
  expect_same(control::SafetyOptions::load(file), control::SafetyOptions{});
}

TEST(ShippedConfig, ObserverYamlIsTheDefaultsWithTheObserverOn) {
  control::PositionControllerOptions on;
  on.disturbance_observer = true;
  expect_same(control::PositionControllerOptions::load(kConfig / "controller_observer.yaml"), on);
}

TEST(ShippedConfig, ImuYamlEqualsTheDefaultNoise) {
  const io::ImuNoise a = io::load_imu_noise(kConfig / "imu_default.yaml");
  const io::ImuNoise b = sim::default_vehicle_imu_noise();
  EXPECT_EQ(a.gyro_noise_density, b.gyro_noise_density);
  EXPECT_EQ(a.gyro_random_walk, b.gyro_random_walk);
  EXPECT_EQ(a.accel_noise_density, b.accel_noise_density);
  EXPECT_EQ(a.accel_random_walk, b.accel_random_walk);
  EXPECT_EQ(a.rate_hz, b.rate_hz);
}

TEST(Options, PrintLoadRoundTripAndErrors) {
  const auto dir = test::fresh_temp_dir("control_options");
  control::PositionControllerOptions o;
  o.position_gain_xy = 0.75;
  o.max_tilt_deg = 25.0;
  {
    std::ofstream f(dir / "c.yaml");
    f << "controller:\n";
    std::istringstream lines(o.to_yaml());
    for (std::string line; std::getline(lines, line);) f << "  " << line << "\n";
  }
  expect_same(control::PositionControllerOptions::load(dir / "c.yaml"), o);

  {
    std::ofstream f(dir / "typo.yaml");
    f << "position_gain_yx: 1.0\n";
  }
  try {
    control::PositionControllerOptions::load(dir / "typo.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("position_gain_yx"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("typo.yaml"), std::string::npos) << e.what();
  }
  {
    std::ofstream f(dir / "bad.yaml");
    f << "vehicle:\n  mass_kg: -1\n";
  }
  EXPECT_THROW(sim::QuadrotorParameters::load(dir / "bad.yaml"), InputError);
  {
    std::ofstream f(dir / "vec.yaml");
    f << "inertia_kg_m2: [0.01, 0.02]\n";
  }
  EXPECT_THROW(sim::QuadrotorParameters::load(dir / "vec.yaml"), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel
