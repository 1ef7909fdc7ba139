// A model of the attitude-stabilising flight controller the thesis flies with (DJI Naza,
// thesis 4.4): it reads four RC pulse widths (1000-2000 us: roll angle, pitch angle, throttle
// = collective thrust, yaw rate) and drives the four motors through an attitude loop, a body
// rate PI loop and an X mixer. It keeps emitting what the last pulses asked for: like a real
// receiver in "hold" mode it does not notice that the companion computer has stopped.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>
#include <string>

#include "kestrel/control/types.hpp"
#include "kestrel/sim/quadrotor.hpp"

namespace kestrel::sim {

struct FlightControllerModelOptions {
  // --- RC decoding: stick = (us - centre) / half range, zero within the deadband ---
  int channel_min_us = 1000;
  int channel_centre_us = 1500;
  int channel_max_us = 2000;
  int deadband_us = 8;                ///< around the centre of roll, pitch and yaw
  int throttle_idle_us = 1050;        ///< at or below: motors at idle, controllers reset
  double max_tilt_deg = 45.0;         ///< full roll/pitch stick (table C.3)
  double max_yaw_rate_deg_s = 200.0;  ///< full yaw stick (table C.3)
  /// Full throttle asks for this fraction of the rotors' maximum total thrust.
  double max_throttle_thrust_fraction = 1.0;

  // --- attitude (P on the rotation error) and body-rate (PI) loops ---
  double attitude_gain_rp = 7.0;  ///< rad/s per rad, roll and pitch
  double attitude_gain_yaw = 3.0;
  double rate_gain_rp = 22.0;  ///< 1/s: angular acceleration per rad/s of rate error
  double rate_gain_yaw = 8.0;
  double rate_integral_gain = 10.0;    ///< 1/s^2
  double rate_integral_limit = 2.0;    ///< rad/s^2, anti-windup clamp
  double max_body_rate_deg_s = 300.0;  ///< the attitude loop never asks for more

  void validate() const;
  [[nodiscard]] std::string to_yaml() const;
  static FlightControllerModelOptions from_yaml(const YAML::Node& node, const std::string& source);
  /// The options at the top level or under a `flight_controller:` key.
  static FlightControllerModelOptions load(const std::filesystem::path& path);

  template <typename V>
  void visit_fields(V&& v) {
    v("channel_min_us", channel_min_us);
    v("channel_centre_us", channel_centre_us);
    v("channel_max_us", channel_max_us);
    v("deadband_us", deadband_us);
    v("throttle_idle_us", throttle_idle_us);
    v("max_tilt_deg", max_tilt_deg);
    v("max_yaw_rate_deg_s", max_yaw_rate_deg_s);
    v("max_throttle_thrust_fraction", max_throttle_thrust_fraction);
    v("attitude_gain_rp", attitude_gain_rp);
    v("attitude_gain_yaw", attitude_gain_yaw);
    v("rate_gain_rp", rate_gain_rp);
    v("rate_gain_yaw", rate_gain_yaw);
    v("rate_integral_gain", rate_integral_gain);
    v("rate_integral_limit", rate_integral_limit);
    v("max_body_rate_deg_s", max_body_rate_deg_s);
  }
};

/// The pulses as the flight controller reads them: sticks in [-1, 1], throttle in [0, 1].
struct DecodedSticks {
  double roll = 0.0;
  double pitch = 0.0;
  double throttle = 0.0;
  double yaw = 0.0;
  bool idle = true;  ///< throttle at or below throttle_idle_us
};

class FlightControllerModel {
 public:
  FlightControllerModel(FlightControllerModelOptions options, QuadrotorParameters vehicle);

  [[nodiscard]] DecodedSticks decode(const control::PwmChannels& pwm) const;

  /// One control cycle of dt_s on the vehicle's true attitude and rates (the flight
  /// controller's own IMU is taken as perfect): the rotor speed commands for Quadrotor::step.
  Eigen::Vector4d update(double dt_s, const control::PwmChannels& pwm, const QuadrotorState& state);

  /// The attitude the last update aimed for.
  [[nodiscard]] const SO3& R_world_desired() const { return R_world_desired_; }
  [[nodiscard]] const FlightControllerModelOptions& options() const { return options_; }

 private:
  FlightControllerModelOptions options_;
  QuadrotorParameters vehicle_;
  Eigen::Matrix4d allocation_inverse_;
  double yaw_target_rad_ = 0.0;
  bool yaw_target_set_ = false;
  Eigen::Vector3d rate_integral_ = Eigen::Vector3d::Zero();
  SO3 R_world_desired_;
};

}  // namespace kestrel::sim
