// Safety supervisor (odometry loss, estimator failure, landing), command bounds, watchdog.
#include "kestrel/control/safety.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::control {

namespace {

AttitudeThrustCommand level(double thrust_N) {
  AttitudeThrustCommand c;
  c.thrust_N = thrust_N;
  return c;
}
}  // namespace

std::string_view to_string(SafetyMode mode) {
  switch (mode) {
    case SafetyMode::kNominal:
      return "nominal";
    case SafetyMode::kImuHold:
      return "imu_hold";
    case SafetyMode::kLanding:
      return "landing";
    case SafetyMode::kBlindDescent:
      return "blind_descent";
    case SafetyMode::kLanded:
      return "landed";
  }
  return "?";
}

std::string_view to_string(WatchdogState state) {
  switch (state) {
    case WatchdogState::kActive:
      return "active";
    case WatchdogState::kTripped:
      return "tripped";
    case WatchdogState::kCutOff:
      return "cut_off";
  }
  return "?";
}

void SafetyOptions::validate() const {
  auto pos = [](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError(std::string("safety option '") + name + "': must be positive");
  };
  pos("vision_timeout_s", vision_timeout_s);
  pos("imu_hold_timeout_s", imu_hold_timeout_s);
  pos("max_position_sigma_m", max_position_sigma_m);
  pos("landing_speed_m_s", landing_speed_m_s);
  if (!std::isfinite(ground_z_m)) throw InputError("safety option 'ground_z_m': must be finite");
  pos("landed_height_m", landed_height_m);
  pos("landed_speed_m_s", landed_speed_m_s);
  pos("landed_hold_s", landed_hold_s);
  pos("blind_descent_thrust_fraction", blind_descent_thrust_fraction);
  if (blind_descent_thrust_fraction >= 1.0) {
    throw InputError(
        "safety option 'blind_descent_thrust_fraction': must be below 1 (else it climbs)");
  }
  pos("blind_descent_max_s", blind_descent_max_s);
}

std::string SafetyOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

SafetyOptions SafetyOptions::from_yaml(const YAML::Node& node, const std::string& source) {
  SafetyOptions o;
  io::option_fields::read_fields(node, source, "safety", o);
  o.validate();
  return o;
}

SafetyOptions SafetyOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["safety"]) return from_yaml(root["safety"], path.string());
  return from_yaml(root, path.string());
}

SafetySupervisor::SafetySupervisor(SafetyOptions options) : options_(std::move(options)) {
  options_.validate();
}

void SafetySupervisor::enter(SafetyMode mode, TimeNs t_ns, std::string reason) {
  mode_ = mode;
  mode_since_ns_ = t_ns;
  reason_ = std::move(reason);
  low_since_ns_.reset();
}

SafetyDecision SafetySupervisor::update(TimeNs t_ns, const VehicleStateEstimate& est,
                                        const EstimatorHealth& health,
                                        const PositionReference& mission, double hover_thrust_N) {
  transition(t_ns, est, health, hover_thrust_N);
  check_touchdown(t_ns, est, mission);
  return decide(t_ns, est, mission);
}

void SafetySupervisor::transition(TimeNs t_ns, const VehicleStateEstimate& est,
                                  const EstimatorHealth& health, double hover_thrust_N) {
  const auto& o = options_;
  const bool estimate_failed = !health.estimate_valid || !finite_estimate(est) ||
                               !(health.position_sigma_m <= o.max_position_sigma_m);
  const bool vision_ok = ns_to_s(t_ns - health.last_vision_update_ns) <= o.vision_timeout_s;
  const double hover = std::isfinite(hover_thrust_N) && hover_thrust_N > 0.0 ? hover_thrust_N : 0.0;

  // Estimator failure is latched: a filter that diverged once is not trusted again in this
  // flight.
  if (mode_ != SafetyMode::kLanded && mode_ != SafetyMode::kBlindDescent && estimate_failed) {
    enter(SafetyMode::kBlindDescent, t_ns,
          !health.estimate_valid  ? "estimator reports failure"
          : !finite_estimate(est) ? "estimate is not finite"
                                  : "position uncertainty above max_position_sigma_m");
    blind_thrust_N_ = o.blind_descent_thrust_fraction * hover;
  }
  switch (mode_) {
    case SafetyMode::kNominal:
      if (!vision_ok) {
        hold_ = PositionReference{};
        hold_.p_world = est.p_world;
        hold_.yaw_rad = yaw_of(est.R_world_body);
        enter(SafetyMode::kImuHold, t_ns, "odometry lost: holding on the IMU");
      }
      break;
    case SafetyMode::kImuHold:
      if (vision_ok) {
        enter(SafetyMode::kNominal, t_ns, "");
      } else if (ns_to_s(t_ns - mode_since_ns_) > o.imu_hold_timeout_s) {
        landing_start_z_ = est.p_world.z();
        enter(SafetyMode::kLanding, t_ns,
              "odometry lost for longer than imu_hold_timeout_s: landing");
      }
      break;
    case SafetyMode::kLanding:
      if (vision_ok && o.resume_when_landing) enter(SafetyMode::kNominal, t_ns, "");
      break;
    case SafetyMode::kBlindDescent:
      if (ns_to_s(t_ns - mode_since_ns_) > o.blind_descent_max_s) {
        enter(SafetyMode::kLanded, t_ns, "blind descent finished: motors off");
      }
      break;
    case SafetyMode::kLanded:
      break;
  }
}

// Touchdown at the end of a mission that lands: once the vehicle has flown, a mission
// reference resting on the ground and an estimate low and still on it for landed_hold_s mean
// it has landed (motors off), also when the odometry was lost in the last centimetres (a
// forward camera near the floor sees it closer than its stereo range).
void SafetySupervisor::check_touchdown(TimeNs t_ns, const VehicleStateEstimate& est,
                                       const PositionReference& mission) {
  const auto& o = options_;
  const double height = est.p_world.z() - o.ground_z_m;
  if (height > 2.0 * o.landed_height_m) airborne_ = true;
  const bool mission_on_ground = mission.p_world.z() - o.ground_z_m < o.landed_height_m &&
                                 mission.v_world.norm() < o.landed_speed_m_s;
  const bool low_and_still =
      height < o.landed_height_m && std::abs(est.v_world.z()) < o.landed_speed_m_s;
  if (airborne_ && mission_on_ground && low_and_still &&
      (mode_ == SafetyMode::kNominal || mode_ == SafetyMode::kImuHold)) {
    if (!touchdown_since_ns_) {
      touchdown_since_ns_ = t_ns;
    } else if (ns_to_s(t_ns - *touchdown_since_ns_) >= o.landed_hold_s) {
      hold_ = mission;
      enter(SafetyMode::kLanded, t_ns, "touched down at the end of the mission: motors off");
    }
  } else {
    touchdown_since_ns_.reset();
  }
}

// The reference (or the override) the mode flies; a landing that has settled ends here.
SafetyDecision SafetySupervisor::decide(TimeNs t_ns, const VehicleStateEstimate& est,
                                        const PositionReference& mission) {
  const auto& o = options_;
  SafetyDecision d;
  d.mode = mode_;
  d.reason = reason_;
  switch (mode_) {
    case SafetyMode::kNominal:
      d.reference = mission;
      break;
    case SafetyMode::kImuHold:
      if (o.hold_flies_mission) hold_ = mission;
      d.reference = hold_;
      break;
    case SafetyMode::kLanding: {
      d.reference = hold_;
      const double t = ns_to_s(t_ns - mode_since_ns_);
      // The reference goes 0.3 m below the floor so that the vehicle presses down on touchdown.
      const double z = landing_start_z_ - o.landing_speed_m_s * t;
      d.reference.p_world.z() = std::max(z, o.ground_z_m - 0.3);
      if (z > o.ground_z_m - 0.3) d.reference.v_world.z() = -o.landing_speed_m_s;
      const bool low = est.p_world.z() - o.ground_z_m < o.landed_height_m &&
                       std::abs(est.v_world.z()) < o.landed_speed_m_s;
      if (!low) {
        low_since_ns_.reset();
      } else if (!low_since_ns_) {
        low_since_ns_ = t_ns;
      } else if (ns_to_s(t_ns - *low_since_ns_) >= o.landed_hold_s) {
        enter(SafetyMode::kLanded, t_ns, "landed");
        d.mode = mode_;
        d.reason = reason_;
      }
      break;
    }
    case SafetyMode::kBlindDescent:
      d.override_command = level(blind_thrust_N_);
      break;
    case SafetyMode::kLanded:
      break;
  }
  if (d.mode == SafetyMode::kLanded) {
    d.reference = hold_;
    d.override_command = level(0.0);
    d.motors_off = true;
  }
  return d;
}

BoundedCommand bound_command(const AttitudeThrustCommand& c, const CommandLimits& l,
                             double fallback_thrust_N) {
  BoundedCommand b;
  auto bound = [&](double v, double lo, double hi, double fallback) {
    if (!std::isfinite(v)) {
      b.non_finite = true;
      return fallback;
    }
    if (v < lo || v > hi) b.clipped = true;
    return std::clamp(v, lo, hi);
  };
  const double tilt = l.max_tilt_deg * kDegToRad;
  const double yaw_rate = l.max_yaw_rate_deg_s * kDegToRad;
  b.command.roll_rad = bound(c.roll_rad, -tilt, tilt, 0.0);
  b.command.pitch_rad = bound(c.pitch_rad, -tilt, tilt, 0.0);
  b.command.yaw_rate_rad_s = bound(c.yaw_rate_rad_s, -yaw_rate, yaw_rate, 0.0);
  b.command.thrust_N = bound(c.thrust_N, l.min_thrust_N, l.max_thrust_N,
                             std::clamp(fallback_thrust_N, l.min_thrust_N, l.max_thrust_N));
  return b;
}

CommandWatchdog::CommandWatchdog(WatchdogOptions options)
    : options_(options), hover_thrust_N_(options.hover_thrust_N) {
  auto pos = [](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError(std::string("watchdog option '") + name + "': must be positive");
  };
  pos("command_timeout_s", options_.command_timeout_s);
  pos("descent_thrust_fraction", options_.descent_thrust_fraction);
  pos("descent_max_s", options_.descent_max_s);
  pos("hover_thrust_N", options_.hover_thrust_N);
  pos("hover_learning_time_s", options_.hover_learning_time_s);
}

void CommandWatchdog::submit(TimeNs t_ns, const AttitudeThrustCommand& command) {
  if (cut_off_) return;
  if (last_submit_ns_ && std::isfinite(command.thrust_N)) {
    // Learn the hover thrust from the vertical part of what the controller commands.
    const double dt = std::clamp(ns_to_s(t_ns - *last_submit_ns_), 0.0, 0.1);
    const double vertical =
        command.thrust_N * std::cos(command.roll_rad) * std::cos(command.pitch_rad);
    if (std::isfinite(vertical) && vertical > 0.0) {
      hover_thrust_N_ += dt / options_.hover_learning_time_s * (vertical - hover_thrust_N_);
    }
  }
  last_submit_ns_ = t_ns;
  last_command_ = command;
}

WatchdogOutput CommandWatchdog::output(TimeNs t_ns) {
  WatchdogOutput out;
  if (!last_submit_ns_ && !cut_off_) {
    out.motors_off = true;  // nothing commanded yet: nothing to fly
    return out;
  }
  const double silent_s = last_submit_ns_ ? ns_to_s(t_ns - *last_submit_ns_) : 0.0;
  if (!cut_off_ && silent_s > options_.command_timeout_s + options_.descent_max_s) cut_off_ = true;
  if (cut_off_) {
    out.state = WatchdogState::kCutOff;
    out.motors_off = true;
    return out;
  }
  if (silent_s > options_.command_timeout_s) {
    out.state = WatchdogState::kTripped;
    out.command = level(options_.descent_thrust_fraction * hover_thrust_N_);
    return out;
  }
  out.command = last_command_;
  return out;
}

void CommandWatchdog::rearm() {
  cut_off_ = false;
  last_submit_ns_.reset();
}

}  // namespace kestrel::control
