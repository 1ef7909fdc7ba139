// Attitude/thrust commands -> the four RC pulse widths a flight controller reads (thesis 4.4:
// the Jetson drives the Naza through PWM channels), with per-channel calibration (end points,
// centre, deadband, direction) and hard limits that no command can pass.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <filesystem>
#include <string>

#include "kestrel/control/types.hpp"

namespace kestrel::control {

/// One RC channel as the flight controller was calibrated to it.
struct ChannelCalibration {
  int min_us = 1000;     ///< hard lower limit, full negative stick (or zero throttle)
  int centre_us = 1500;  ///< neutral stick (ignored for the throttle)
  int max_us = 2000;     ///< hard upper limit
  /// The flight controller ignores |us - centre| <= deadband; non-zero commands are placed
  /// just outside it so that small corrections are not lost.
  int deadband_us = 8;
  bool reversed = false;  ///< the channel's direction is inverted in the wiring / radio
};

struct PwmMapperOptions {
  /// Roll, pitch, throttle, yaw (PwmChannels order).
  std::array<ChannelCalibration, 4> channels{};
  double full_stick_tilt_deg = 45.0;         ///< tilt at full roll/pitch stick (table C.3)
  double full_stick_yaw_rate_deg_s = 200.0;  ///< yaw rate at full yaw stick (table C.3)
  double full_throttle_thrust_N = 28.0;      ///< collective thrust at max throttle
  /// The mapped throttle never drops below this while flying (motors keep spinning); only
  /// PwmMapper::motors_off() goes lower.
  int flight_min_throttle_us = 1060;

  void validate() const;
  [[nodiscard]] std::string to_yaml() const;
  static PwmMapperOptions from_yaml(const YAML::Node& node, const std::string& source);
  /// The options at the top level or under a `pwm:` key.
  static PwmMapperOptions load(const std::filesystem::path& path);

  template <typename V>
  void visit_fields(V&& v) {
    static const std::array<std::string, 4> names{"roll", "pitch", "throttle", "yaw"};
    for (std::size_t i = 0; i < 4; ++i) {
      v((names[i] + "_min_us").c_str(), channels[i].min_us);
      v((names[i] + "_centre_us").c_str(), channels[i].centre_us);
      v((names[i] + "_max_us").c_str(), channels[i].max_us);
      v((names[i] + "_deadband_us").c_str(), channels[i].deadband_us);
      v((names[i] + "_reversed").c_str(), channels[i].reversed);
    }
    v("full_stick_tilt_deg", full_stick_tilt_deg);
    v("full_stick_yaw_rate_deg_s", full_stick_yaw_rate_deg_s);
    v("full_throttle_thrust_N", full_throttle_thrust_N);
    v("flight_min_throttle_us", flight_min_throttle_us);
  }
};

/// RC conventions: roll > centre lowers the right side, pitch > centre lowers the nose,
/// yaw > centre turns clockwise seen from above (negative yaw rate about z-up).
class PwmMapper {
 public:
  explicit PwmMapper(PwmMapperOptions options = {});

  /// Commands outside the channels' ranges are clipped to the hard limits; non-finite values
  /// map to neutral sticks and the flight minimum throttle.
  [[nodiscard]] PwmChannels map(const AttitudeThrustCommand& command) const;
  /// The command that `pwm` stands for (the inverse of map within the ranges; deadband -> 0).
  [[nodiscard]] AttitudeThrustCommand unmap(const PwmChannels& pwm) const;
  /// Neutral sticks, throttle at its minimum: motors stop (idle) on the flight controller.
  [[nodiscard]] PwmChannels motors_off() const;
  [[nodiscard]] const PwmMapperOptions& options() const { return options_; }

 private:
  [[nodiscard]] int stick_to_us(int channel, double stick) const;
  [[nodiscard]] double us_to_stick(int channel, int us) const;
  PwmMapperOptions options_;
};

}  // namespace kestrel::control
