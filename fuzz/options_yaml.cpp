// The options YAMLs (io/option_fields.hpp tables, unknown keys refused, then each struct's
// validate()): every loader a user can point at a file, on every input, so that a mutation of
// one kind of file is also tried on the others.
#include "fuzz_input.hpp"
#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"
#include "kestrel/pipeline/controller_options.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sim/flight_controller_model.hpp"
#include "kestrel/sim/quadrotor.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/sensor_noise.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("options.yaml");
  const auto& path = file.write(data, size);
  using kestrel::fuzz::expect_parsed_or_refused;
  using namespace kestrel;
  expect_parsed_or_refused([&] { (void)odometry::DirectTrackerOptions::load(path); });
  expect_parsed_or_refused([&] { (void)sensor::BlockMatcherOptions::load_yaml(path); });
  expect_parsed_or_refused([&] { (void)driver::StereoDecoderOptions::load_yaml(path); });
  expect_parsed_or_refused([&] { (void)fusion::FusionOptions::load_yaml(path); });
  expect_parsed_or_refused([&] { (void)control::PositionControllerOptions::load(path); });
  expect_parsed_or_refused([&] { (void)control::PwmMapperOptions::load(path); });
  expect_parsed_or_refused([&] { (void)control::SafetyOptions::load(path); });
  expect_parsed_or_refused([&] { (void)sim::QuadrotorParameters::load(path); });
  expect_parsed_or_refused([&] { (void)sim::FlightControllerModelOptions::load(path); });
  expect_parsed_or_refused([&] { (void)sim::RenderOptions::load_yaml(path); });
  expect_parsed_or_refused([&] { (void)sim::SensorNoiseOptions::load_yaml(path); });
  expect_parsed_or_refused([&] { (void)pipeline::PipelineOptions::load_yaml(path); });
  expect_parsed_or_refused([&] {
    pipeline::ControllerStageOptions controller;
    controller.load_files(path);
  });
  return 0;
}
