// The controller stage's per-state logic (src/pipeline/controller_stage.hpp) driven without
// threads: the control chain on hand-made fused states, its failsafes and the config block.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

#include "config_files.hpp"
#include "controller_stage.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"
#include "test_data.hpp"

namespace kestrel::pipeline {
namespace {

namespace fs = std::filesystem;
constexpr TimeNs kMs = 1'000'000;
constexpr TimeNs kT0 = 1'000'000'000'000;  // an arbitrary, large start time (as EuRoC's)

// A fused state of a vehicle standing at p, level, facing +x, after an accepted update.
fusion::FusedState standing(TimeNs t_ns, const Eigen::Vector3d& p = Eigen::Vector3d(1, 2, 0.5),
                            std::uint32_t flags = fusion::kFlagUpdated) {
  fusion::FusedState s;
  s.t_ns = t_ns;
  s.state.t_ns = t_ns;
  s.state.p_world = p;
  s.sigma.setConstant(0.01);
  s.flags = flags;
  s.at_odometry = true;
  return s;
}

void expect_within_limits(const control::PwmMapper& mapper, const control::PwmChannels& pwm) {
  for (int ch = 0; ch < 4; ++ch) {
    const auto& cal = mapper.options().channels[static_cast<std::size_t>(ch)];
    EXPECT_GE(pwm.us[static_cast<std::size_t>(ch)], cal.min_us) << "channel " << ch;
    EXPECT_LE(pwm.us[static_cast<std::size_t>(ch)], cal.max_us) << "channel " << ch;
  }
}

TEST(ControllerStage, HoldingAStandingVehicleCommandsHoverThrustLevel) {
  ControllerStage stage(ControllerStageOptions{}, /*fused=*/true);
  const double weight = ControllerStageOptions{}.controller.mass_kg * control::kGravity;
  for (int i = 0; i < 40; ++i) {
    const TimeNs t = kT0 + i * 50 * kMs;
    const ControllerRecord r = stage.on_state(standing(t), t + 10 * kMs);
    EXPECT_EQ(r.input, ControllerInput::kState);
    EXPECT_EQ(r.mode, control::SafetyMode::kNominal);
    EXPECT_EQ(r.watchdog, control::WatchdogState::kActive);
    EXPECT_FALSE(r.motors_off);
    // Zero position and velocity error: the gravity feed-forward alone, level, no yaw.
    EXPECT_NEAR(r.command.thrust_N, weight, 1e-6);
    EXPECT_NEAR(r.command.roll_rad, 0.0, 1e-9);
    EXPECT_NEAR(r.command.pitch_rad, 0.0, 1e-9);
    EXPECT_NEAR(r.command.yaw_rate_rad_s, 0.0, 1e-9);
    EXPECT_EQ(r.pwm, stage.mapper().map(r.command));
    EXPECT_NE(r.pwm, stage.mapper().motors_off());
    expect_within_limits(stage.mapper(), r.pwm);
    EXPECT_EQ(r.p_ref, Eigen::Vector3d(1, 2, 0.5));  // the first pose is held
  }
}

TEST(ControllerStage, ASetpointAboveClimbsAndOneToTheSideTilts) {
  ControllerStageOptions o;
  o.setpoint = Eigen::Vector4d(1.0, 3.0, 1.5, 0.0);  // 1 m up, 1 m to the left (+y)
  ControllerStage stage(o, true);
  const ControllerRecord r = stage.on_state(standing(kT0), kT0);
  EXPECT_EQ(r.p_ref, Eigen::Vector3d(1.0, 3.0, 1.5));
  EXPECT_GT(r.command.thrust_N, o.controller.mass_kg * control::kGravity + 1.0);
  EXPECT_LT(r.command.roll_rad, -0.05);  // -roll accelerates towards +y (docs/control.md)
}

TEST(ControllerStage, StatesThatStopGiveTheWatchdogFailsafeThenMotorsOff) {
  ControllerStageOptions o;
  ControllerStage stage(o, true);
  EXPECT_FALSE(stage.on_silence(kT0).has_value());  // nothing before the first state
  const ControllerRecord last = stage.on_state(standing(kT0), kT0);
  const control::WatchdogOptions& w = o.watchdog;
  const auto at = [&](double s) { return kT0 + static_cast<TimeNs>(s * 1e9); };
  // Within the timeout the last command holds.
  auto r = stage.on_silence(at(0.5 * w.command_timeout_s));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->input, ControllerInput::kNoState);
  EXPECT_EQ(r->watchdog, control::WatchdogState::kActive);
  EXPECT_EQ(r->pwm, last.pwm);
  // Past it: level, the descent fraction of the hover thrust it had learnt.
  r = stage.on_silence(at(w.command_timeout_s + 0.05));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->watchdog, control::WatchdogState::kTripped);
  EXPECT_NEAR(r->command.roll_rad, 0.0, 1e-12);
  EXPECT_NEAR(r->command.thrust_N, w.descent_thrust_fraction * w.hover_thrust_N, 1e-6);
  EXPECT_LT(r->pwm.us[control::PwmChannels::kThrottle],
            last.pwm.us[control::PwmChannels::kThrottle]);
  EXPECT_FALSE(r->motors_off);
  // After the descent time: cut off.
  r = stage.on_silence(at(w.command_timeout_s + w.descent_max_s + 0.1));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->watchdog, control::WatchdogState::kCutOff);
  EXPECT_TRUE(r->motors_off);
  EXPECT_EQ(r->pwm, stage.mapper().motors_off());
}

TEST(ControllerStage, AStateOlderThanTheWatchdogTimeoutIsNotFlown) {
  ControllerStageOptions o;
  ControllerStage stage(o, true);
  const ControllerRecord first = stage.on_state(standing(kT0), kT0);
  // The next state comes 0.5 s late (older than the 0.25 s timeout) and 1 m off: not flown.
  const TimeNs t = kT0 + 50 * kMs;
  const ControllerRecord r = stage.on_state(standing(t, Eigen::Vector3d(0, 0, 0)), t + 500 * kMs);
  EXPECT_EQ(r.input, ControllerInput::kStaleState);
  EXPECT_EQ(r.watchdog, control::WatchdogState::kTripped);  // its last command is 0.55 s old
  EXPECT_NE(r.pwm, first.pwm);
  EXPECT_NEAR(r.command.thrust_N, o.watchdog.descent_thrust_fraction * o.watchdog.hover_thrust_N,
              1e-6);
}

TEST(ControllerStage, OdometryDropoutFlagsHoldThenLand) {
  ControllerStageOptions o;
  ControllerStage stage(o, true);
  (void)stage.on_state(standing(kT0), kT0);
  control::SafetyMode mode = control::SafetyMode::kNominal;
  double hold_s = -1.0, land_s = -1.0;
  for (int i = 1; i <= 200; ++i) {  // 10 s of states without an accepted update
    const TimeNs t = kT0 + i * 50 * kMs;
    const ControllerRecord r =
        stage.on_state(standing(t, Eigen::Vector3d(1, 2, 0.5), fusion::kFlagVoDropout), t);
    if (r.mode == control::SafetyMode::kImuHold && hold_s < 0) hold_s = i * 0.05;
    if (r.mode == control::SafetyMode::kLanding && land_s < 0) land_s = i * 0.05;
    mode = r.mode;
    EXPECT_EQ(r.watchdog, control::WatchdogState::kActive);  // states keep coming
  }
  EXPECT_NEAR(hold_s, o.safety.vision_timeout_s, 0.051);
  EXPECT_NEAR(land_s, o.safety.vision_timeout_s + o.safety.imu_hold_timeout_s, 0.11);
  EXPECT_EQ(mode, control::SafetyMode::kLanding);
  // An accepted update afterwards does not resume the mission (resume_when_landing false).
  const TimeNs t = kT0 + 201 * 50 * kMs;
  EXPECT_EQ(stage.on_state(standing(t), t).mode, control::SafetyMode::kLanding);
}

TEST(ControllerStage, AnUnusableEstimateIsABlindDescent) {
  ControllerStage stage(ControllerStageOptions{}, true);
  (void)stage.on_state(standing(kT0), kT0);
  fusion::FusedState s = standing(kT0 + 50 * kMs);
  s.sigma.setConstant(2.0);  // above max_position_sigma_m
  const ControllerRecord r = stage.on_state(s, s.t_ns);
  EXPECT_EQ(r.mode, control::SafetyMode::kBlindDescent);
  EXPECT_NEAR(r.command.roll_rad, 0.0, 1e-12);
  EXPECT_LT(r.command.thrust_N, ControllerStageOptions{}.controller.mass_kg * control::kGravity);
}

TEST(ControllerStage, UnfusedStatesAreNotFlownUnlessAllowed) {
  fusion::FusedState s = standing(kT0);
  s.sigma.setConstant(std::numeric_limits<double>::quiet_NaN());  // as the pass-through's
  s.flags = 0;
  ControllerStage refused(ControllerStageOptions{}, /*fused=*/false);
  EXPECT_TRUE(refused.disarmed());
  for (int i = 0; i < 5; ++i) {
    s.t_ns = kT0 + i * 50 * kMs;
    const ControllerRecord r = refused.on_state(s, s.t_ns);
    EXPECT_TRUE(r.disarmed);
    EXPECT_TRUE(r.motors_off);
    EXPECT_EQ(r.pwm, refused.mapper().motors_off());
    EXPECT_EQ(r.command.thrust_N, 0.0);
  }
  EXPECT_TRUE(refused.on_silence(kT0 + 10'000 * kMs)->motors_off);

  ControllerStageOptions allow;
  allow.allow_unfused = true;
  ControllerStage allowed(allow, false);
  s.t_ns = kT0;
  const ControllerRecord r = allowed.on_state(s, s.t_ns);
  EXPECT_FALSE(r.disarmed);
  EXPECT_EQ(r.mode, control::SafetyMode::kNominal);  // unknown sigma is not a failure
  EXPECT_NEAR(r.command.thrust_N, allow.controller.mass_kg * control::kGravity, 1e-6);
}

TEST(ControllerStage, VehicleAxesSetTheHeading) {
  // EuRoC's IMU frame: x up, y right, z forward. A body rotated so that its z points along
  // world +y (and x up) faces +y: the held yaw is 90 degrees.
  ControllerStageOptions o;
  o.R_body_vehicle = parse_vehicle_axes({"+z", "-y", "+x"});
  ControllerStage stage(o, true);
  fusion::FusedState s = standing(kT0);
  Eigen::Matrix3d R_world_body;
  R_world_body.col(0) = Eigen::Vector3d::UnitZ();  // body x up
  R_world_body.col(1) = Eigen::Vector3d::UnitX();  // body y (right) along world +x
  R_world_body.col(2) = Eigen::Vector3d::UnitY();  // body z (forward) along world +y
  s.state.q_world_body = SO3::from_matrix(R_world_body).unit_quaternion();
  const ControllerRecord r = stage.on_state(s, kT0);
  EXPECT_NEAR(r.yaw_ref_rad, std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(r.command.yaw_rate_rad_s, 0.0, 1e-9);
  EXPECT_THROW(parse_vehicle_axes({"+z", "+y", "+x"}), InputError);  // left-handed
  EXPECT_THROW(parse_vehicle_axes({"+z", "+z", "+x"}), InputError);
  EXPECT_THROW(parse_vehicle_axes({"up", "-y", "+x"}), InputError);
}

// --- the `controller:` block of a pipeline config ---

TEST(ControllerStageOptions, DefaultsAndFieldsLoad) {
  const fs::path dir = test::fresh_temp_dir("controller");
  EXPECT_FALSE(PipelineOptions::load_yaml(test::write_text(dir / "a.yaml", "input: x\n"))
                   .controller.setpoint.has_value());
  test::write_text(dir / "ctl.yaml",
                   "controller:\n  mass_kg: 1.5\nsafety:\n  vision_timeout_s: 0.5\n");
  const PipelineOptions o = PipelineOptions::load_yaml(
      test::write_text(dir / "b.yaml",
                       "input: x\ncontroller:\n  setpoint: [1, 2, 3, 90]\n  allow_unfused: true\n"
                       "  controller_options: ctl.yaml\n  output: c.csv\n"));
  ASSERT_TRUE(o.controller.setpoint.has_value());
  EXPECT_NEAR((*o.controller.setpoint)[2], 3.0, 1e-12);
  EXPECT_NEAR((*o.controller.setpoint)[3], std::numbers::pi / 2, 1e-12);  // degrees in the file
  EXPECT_TRUE(o.controller.allow_unfused);
  EXPECT_EQ(o.controller.controller_options_file, dir / "ctl.yaml");
  EXPECT_EQ(o.controller.controller.mass_kg, 1.5);
  EXPECT_EQ(o.controller.safety.vision_timeout_s, 0.5);
  EXPECT_EQ(o.controller.pwm.flight_min_throttle_us,
            control::PwmMapperOptions{}.flight_min_throttle_us);
  EXPECT_EQ(o.controller.output, "c.csv");
  // The shipped control defaults load through the block.
  const fs::path shipped = fs::path(KESTREL_SOURCE_DIR) / "config" / "controller_default.yaml";
  test::write_text(dir / "c.yaml",
                   "input: x\ncontroller:\n  controller_options: " + shipped.string() + "\n");
  EXPECT_EQ(PipelineOptions::load_yaml(dir / "c.yaml").controller.controller.mass_kg,
            control::PositionControllerOptions{}.mass_kg);
}

TEST(ControllerStageOptions, ErrorsNameTheConfigFileAndField) {
  const fs::path dir = test::fresh_temp_dir("controller");
  struct Case {
    std::string yaml, field, message;
  };
  test::write_text(dir / "typo.yaml", "controller:\n  mass_kgg: 1.5\n");
  test::write_text(dir / "section.yaml", "controllers:\n  mass_kg: 1.5\n");
  test::write_text(dir / "heavy.yaml", "controller:\n  mass_kg: 5\n");
  const Case cases[] = {
      {"controller:\n  setpoint: hover\n", "'controller.setpoint'", "hold or [x_m"},
      {"controller:\n  setpoint: [1, 2, 3]\n", "'controller.setpoint'", "hold or [x_m"},
      {"controller:\n  setpoint: [1, 2, a, 0]\n", "'controller.setpoint'", "wrong type"},
      {"controller:\n  allow_unfused: perhaps\n", "'controller.allow_unfused'", "wrong type"},
      {"controller:\n  vehicle_axes: [+z, +y, +x]\n", "'controller.vehicle_axes'", "right-handed"},
      {"controller:\n  silence_check_s: 0\n", "'controller.silence_check_s'", "(0, 1]"},
      {"controller:\n  setpont: hold\n", "'controller.setpont'", "is not a pipeline option"},
      {"controller:\n  controller_options: missing.yaml\n", "'controller.controller_options'",
       "missing.yaml"},
      {"controller:\n  controller_options: typo.yaml\n", "'controller.controller_options'",
       "'controller.mass_kgg'"},
      {"controller:\n  controller_options: section.yaml\n", "'controller.controller_options'",
       "'controllers'"},
      {"controller:\n  controller_options: heavy.yaml\n", "'controller.controller_options'",
       "max_thrust_N"},
      {"controller: 3\n", "'controller'", "map"},
      {"controller:\n  output: trajectory.txt\n", "controller.output", "differ"},
  };
  int i = 0;
  for (const Case& c : cases) {
    const fs::path f =
        test::write_text(dir / ("run" + std::to_string(i++) + ".yaml"), "input: x\n" + c.yaml);
    const std::string e = test::config_error_of(f);
    EXPECT_NE(e.find(f.string()), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find(c.field), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find(c.message), std::string::npos) << c.yaml << " -> " << e;
  }
}

}  // namespace
}  // namespace kestrel::pipeline
