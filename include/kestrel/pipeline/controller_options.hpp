// Options of the pipeline's controller stage (the `controller:` block of a `kestrel run`
// config): what to fly (hold the first fused pose, or a set point), the control module's
// controller / PWM / safety options, and whether an unfused state may be flown at all.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::pipeline {

/// `setpoint:` as the options table reads and prints it: `hold` (none) or [x_m, y_m, z_m,
/// yaw_deg], the yaw in degrees in the file and in radians in the options.
struct SetpointField {
  void read(const YAML::Node& node, std::optional<Eigen::Vector4d>& setpoint) const;
  [[nodiscard]] std::string text(const std::optional<Eigen::Vector4d>& setpoint) const;
};

/// `vehicle_axes:` as the options table reads and prints it: [forward, left, up] as body axes
/// ("+z", "-y", ...), see parse_vehicle_axes().
struct VehicleAxesField {
  void read(const YAML::Node& node, SO3& R_body_vehicle) const;
  /// The nearest body axis of each vehicle axis (exact for what read() gives).
  [[nodiscard]] std::string text(const SO3& R_body_vehicle) const;
};

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
  /// period, so that a state arriving a little late is not taken for silence (docs/pipeline.md,
  /// "Controller stage"); well inside the watchdog's 0.25 s timeout.
  double silence_check_s = 0.1;
  /// The file of control options (`controller:`, `pwm:`, `safety:` sections, as
  /// config/controller_default.yaml); empty: the header defaults.
  std::filesystem::path controller_options_file;
  control::PositionControllerOptions controller;
  control::PwmMapperOptions pwm;
  control::SafetyOptions safety;
  control::WatchdogOptions watchdog;                ///< header defaults (no YAML of its own)
  control::CommandLimits limits;                    ///< header defaults (no YAML of its own)
  std::filesystem::path output = "controller.csv";  ///< per-output CSV, under --out

  /// The keys of the `controller:` block (io/option_fields.hpp; PipelineOptions reads the
  /// block). The control options come from the controller_options file, not inline.
  template <typename V>
  void visit_fields(V&& v) {
    v("setpoint", setpoint, SetpointField{});
    v("allow_unfused", allow_unfused);
    v("vehicle_axes", R_body_vehicle, VehicleAxesField{});
    v("silence_check_s", silence_check_s);
    v("controller_options", controller_options_file);
    v("output", output);
  }

  /// Once the block's fields are read: takes controller_options_file from the folder of
  /// `config` and loads its `controller:`, `pwm:` and `safety:` sections. Errors are
  /// InputErrors naming the config file and the field, the options file's own error inside
  /// (`run.yaml: field 'controller.controller_options': ctl.yaml: ...`).
  void load_files(const std::filesystem::path& config);
  /// Throws InputError "field 'controller.<name>': ..." (and the control options' own).
  void validate() const;
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] std::string to_yaml() const;
};

/// "[+z, -y, +x]" style axes -> R_body_vehicle (columns: the vehicle's forward, left, up in
/// body axes). Throws InputError unless each is one of +x -x +y -y +z -z and they form a
/// right-handed frame.
SO3 parse_vehicle_axes(const std::vector<std::string>& axes);

}  // namespace kestrel::pipeline
