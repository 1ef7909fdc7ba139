// PwmMapper: stick scaling with deadband compensation, channel direction and hard limits.
#include "kestrel/control/pwm_mapper.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::control {

namespace {
double finite_or(double v, double fallback) { return std::isfinite(v) ? v : fallback; }
}  // namespace

void PwmMapperOptions::validate() const {
  static const std::array<std::string, 4> names{"roll", "pitch", "throttle", "yaw"};
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& c = channels[i];
    const std::string n = names[i];
    auto fail = [&](const std::string& field, const std::string& why) {
      throw InputError("pwm option '" + n + "_" + field + "': " + why);
    };
    if (c.min_us < 800 || c.max_us > 2200 || c.min_us >= c.max_us) {
      fail("min_us", "the range must satisfy 800 <= min_us < max_us <= 2200");
    }
    if (static_cast<int>(i) != PwmChannels::kThrottle) {
      if (!(c.min_us < c.centre_us && c.centre_us < c.max_us))
        fail("centre_us", "must lie strictly inside the range");
      if (c.deadband_us < 0 ||
          2 * c.deadband_us >= std::min(c.max_us - c.centre_us, c.centre_us - c.min_us)) {
        fail("deadband_us", "must be >= 0 and well inside the half range");
      }
    }
  }
  auto pos = [](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError(std::string("pwm option '") + name + "': must be positive");
  };
  pos("full_stick_tilt_deg", full_stick_tilt_deg);
  pos("full_stick_yaw_rate_deg_s", full_stick_yaw_rate_deg_s);
  pos("full_throttle_thrust_N", full_throttle_thrust_N);
  const auto& t = channels[PwmChannels::kThrottle];
  if (flight_min_throttle_us < t.min_us || flight_min_throttle_us >= t.max_us) {
    throw InputError(
        "pwm option 'flight_min_throttle_us': must lie within [throttle_min_us, throttle_max_us)");
  }
}

std::string PwmMapperOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

PwmMapperOptions PwmMapperOptions::from_yaml(const YAML::Node& node, const std::string& source) {
  PwmMapperOptions o;
  io::option_fields::read_fields(node, source, "pwm", o);
  o.validate();
  return o;
}

PwmMapperOptions PwmMapperOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["pwm"]) return from_yaml(root["pwm"], path.string());
  return from_yaml(root, path.string());
}

PwmMapper::PwmMapper(PwmMapperOptions options) : options_(std::move(options)) {
  options_.validate();
}

int PwmMapper::stick_to_us(int channel, double stick) const {
  const auto& c = options_.channels[static_cast<std::size_t>(channel)];
  double s = std::clamp(finite_or(stick, 0.0), -1.0, 1.0);
  if (c.reversed) s = -s;
  if (s == 0.0) return c.centre_us;
  const double half = s > 0 ? c.max_us - c.centre_us : c.centre_us - c.min_us;
  const double offset = c.deadband_us + std::abs(s) * (half - c.deadband_us);
  const int us = static_cast<int>(std::lround(c.centre_us + std::copysign(offset, s)));
  return std::clamp(us, c.min_us, c.max_us);
}

double PwmMapper::us_to_stick(int channel, int us) const {
  const auto& c = options_.channels[static_cast<std::size_t>(channel)];
  const double d = us - c.centre_us;
  if (std::abs(d) <= c.deadband_us) return 0.0;
  const double half = d > 0 ? c.max_us - c.centre_us : c.centre_us - c.min_us;
  double s =
      std::copysign(std::min(1.0, (std::abs(d) - c.deadband_us) / (half - c.deadband_us)), d);
  return c.reversed ? -s : s;
}

PwmChannels PwmMapper::map(const AttitudeThrustCommand& cmd) const {
  const auto& o = options_;
  PwmChannels pwm;
  const double full_tilt = o.full_stick_tilt_deg * kDegToRad;
  const double full_yaw = o.full_stick_yaw_rate_deg_s * kDegToRad;
  pwm.us[PwmChannels::kRoll] =
      stick_to_us(PwmChannels::kRoll, finite_or(cmd.roll_rad, 0.0) / full_tilt);
  pwm.us[PwmChannels::kPitch] =
      stick_to_us(PwmChannels::kPitch, finite_or(cmd.pitch_rad, 0.0) / full_tilt);
  // RC convention: rudder right (above centre) turns clockwise, i.e. a negative yaw rate.
  pwm.us[PwmChannels::kYaw] =
      stick_to_us(PwmChannels::kYaw, -finite_or(cmd.yaw_rate_rad_s, 0.0) / full_yaw);
  const auto& t = o.channels[PwmChannels::kThrottle];
  const double fraction =
      std::clamp(finite_or(cmd.thrust_N, 0.0) / o.full_throttle_thrust_N, 0.0, 1.0);
  double throttle = t.reversed ? t.max_us - fraction * (t.max_us - t.min_us)
                               : t.min_us + fraction * (t.max_us - t.min_us);
  int us = static_cast<int>(std::lround(throttle));
  if (!t.reversed) us = std::max(us, o.flight_min_throttle_us);
  pwm.us[PwmChannels::kThrottle] = std::clamp(us, t.min_us, t.max_us);
  return pwm;
}

AttitudeThrustCommand PwmMapper::unmap(const PwmChannels& pwm) const {
  const auto& o = options_;
  AttitudeThrustCommand cmd;
  cmd.roll_rad = us_to_stick(PwmChannels::kRoll, pwm.us[PwmChannels::kRoll]) *
                 o.full_stick_tilt_deg * kDegToRad;
  cmd.pitch_rad = us_to_stick(PwmChannels::kPitch, pwm.us[PwmChannels::kPitch]) *
                  o.full_stick_tilt_deg * kDegToRad;
  cmd.yaw_rate_rad_s = -us_to_stick(PwmChannels::kYaw, pwm.us[PwmChannels::kYaw]) *
                       o.full_stick_yaw_rate_deg_s * kDegToRad;
  const auto& t = o.channels[PwmChannels::kThrottle];
  double fraction =
      static_cast<double>(pwm.us[PwmChannels::kThrottle] - t.min_us) / (t.max_us - t.min_us);
  if (t.reversed) fraction = 1.0 - fraction;
  cmd.thrust_N = std::clamp(fraction, 0.0, 1.0) * o.full_throttle_thrust_N;
  return cmd;
}

PwmChannels PwmMapper::motors_off() const {
  PwmChannels pwm;
  for (int i = 0; i < 4; ++i)
    pwm.us[static_cast<std::size_t>(i)] = options_.channels[static_cast<std::size_t>(i)].centre_us;
  const auto& t = options_.channels[PwmChannels::kThrottle];
  pwm.us[PwmChannels::kThrottle] = t.reversed ? t.max_us : t.min_us;
  return pwm;
}

}  // namespace kestrel::control
