// Options of the pipeline's controller stage (the `controller:` block of a `kestrel run`
// config): what to fly (hold the first fused pose, or a set point), the control module's
// controller / PWM / safety options, and whether an unfused state may be flown at all.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::pipeline {

struct ControllerStageOptions {
  /// World set point [x_m, y_m, z_m, yaw_rad]; none (`setpoint: hold`, the default): hover at
  /// the first fused pose. The YAML takes the yaw in degrees ([x, y, z, yaw_deg]).
  std::optional<Eigen::Vector4d> setpoint;
  /// The camera source has no IMU: its states are the odometry passed through (not fused, no
  /// gravity-aligned world, no covariance). False: such states are never flown; the stage
  /// outputs the disarmed PWM (PwmMapper::motors_off) for each.
  bool allow_unfused = false;
  /// The vehicle's forward / left / up axes in the fused body frame, which is the IMU's:
  /// the controller and the supervisor take the heading from the vehicle's forward axis.
  /// Default identity (body = vehicle, as in `kestrel fly`). EuRoC's IMU frame has x up,
  /// y right, z forward: `vehicle_axes: [+z, -y, +x]` (config/pipeline_euroc.yaml).
  SO3 R_body_vehicle;
  /// No state for this long (wall clock): the stage asks the watchdog what to output
  /// (its failsafe once the last command is older than its timeout). Twice a 20 Hz camera's
  /// period: at 0.05 s, one period, V1_01 at the recorded pace logged 7 spurious `none` rows
  /// among 16 states. Well inside the watchdog's 0.25 s timeout either way.
  double silence_check_s = 0.1;
  /// The file of control options (`controller:`, `pwm:`, `safety:` sections, as
  /// config/controller_default.yaml); empty: the header defaults.
  std::filesystem::path controller_options_file;
  control::PositionControllerOptions controller;
  control::PwmMapperOptions pwm;
  control::SafetyOptions safety;
  control::WatchdogOptions watchdog;  ///< header defaults (no YAML of its own)
  control::CommandLimits limits;      ///< header defaults (no YAML of its own)
  std::filesystem::path output = "controller.csv";  ///< per-output CSV, under --out

  /// The `controller:` block of `config`: keys setpoint (hold | [x, y, z, yaw_deg]),
  /// allow_unfused, vehicle_axes ([+z, -y, +x] style), silence_check_s, controller_options
  /// (a file, relative to the config's folder), output. Errors are InputErrors naming the
  /// config file and the field (`run.yaml: field 'controller.setpoint': ...`).
  static ControllerStageOptions from_yaml(const YAML::Node& node,
                                          const std::filesystem::path& config);
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// "[+z, -y, +x]" style axes -> R_body_vehicle (columns: the vehicle's forward, left, up in
/// body axes). Throws InputError unless each is one of +x -x +y -y +z -z and they form a
/// right-handed frame.
SO3 parse_vehicle_axes(const std::vector<std::string>& axes);

}  // namespace kestrel::pipeline
