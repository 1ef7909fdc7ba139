// The controller stage's per-state logic: the control chain of `kestrel fly` on fused states.
#include "controller_stage.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/control/types.hpp"

namespace kestrel::pipeline {

ControllerStage::ControllerStage(ControllerStageOptions options, bool fused)
    : options_(std::move(options)),
      fused_(fused),
      disarmed_(!fused && !options_.allow_unfused),
      controller_(options_.controller),
      mapper_(options_.pwm),
      supervisor_(options_.safety),
      watchdog_(options_.watchdog) {
  options_.validate();
}

control::VehicleStateEstimate ControllerStage::estimate_of(const fusion::FusedState& s) const {
  control::VehicleStateEstimate e;
  e.t_ns = s.t_ns;
  e.p_world = s.state.p_world;
  // A pass-through state has no velocity (zero): the velocity loop then only damps the
  // position loop's command, as if the vehicle stood still.
  e.v_world = s.state.v_world;
  e.R_world_body = SO3(s.state.q_world_body) * options_.R_body_vehicle;
  return e;
}

void ControllerStage::output(TimeNs now_ns, bool motors_off_asked, ControllerRecord& r) {
  const control::WatchdogOutput w = watchdog_.output(now_ns);
  r.watchdog = w.state;
  r.motors_off = motors_off_asked || w.motors_off;
  r.command = r.motors_off ? control::AttitudeThrustCommand{} : w.command;
  r.pwm = r.motors_off ? mapper_.motors_off() : mapper_.map(w.command);
}

ControllerRecord ControllerStage::on_state(const fusion::FusedState& s, TimeNs now_ns) {
  // Decisions never go back in time (a late state is judged at the later clock).
  if (last_now_ns_) now_ns = std::max(now_ns, *last_now_ns_);
  last_now_ns_ = now_ns;
  last_state_t_ns_ = s.t_ns;
  ControllerRecord r;
  r.now_ns = now_ns;
  r.state_t_ns = s.t_ns;
  r.fusion_flags = s.flags;
  r.disarmed = disarmed_;
  r.mode = supervisor_.mode();
  r.p_ref = last_reference_.p_world;
  r.yaw_ref_rad = last_reference_.yaw_rad;
  if (disarmed_) {  // never fed to the watchdog, which therefore keeps the motors off
    output(now_ns, true, r);
    return r;
  }
  if (ns_to_s(now_ns - s.t_ns) > options_.watchdog.command_timeout_s) {
    // Too old to fly on: as if it had not come (the watchdog runs on what it had).
    r.input = ControllerInput::kStaleState;
    output(now_ns, supervisor_.mode() == control::SafetyMode::kLanded, r);
    return r;
  }

  const control::VehicleStateEstimate e = estimate_of(s);
  control::EstimatorHealth health;
  health.estimate_valid = control::finite_estimate(e);
  if (!mission_) {
    // The flight starts with a fresh estimate (as `kestrel fly` starts at t = 0): the first
    // state counts as the last vision update, so a filter that has not updated yet is not a
    // loss of odometry from the start.
    last_vision_update_ns_ = s.t_ns;
  }
  // Odometry accepted by the filter (EKF), or a tracked pose passed through (camera source).
  const bool vision =
      fused_ ? (s.flags & fusion::kFlagUpdated) != 0U && (s.flags & fusion::kFlagVoDropout) == 0U
             : s.at_odometry;
  if (vision) last_vision_update_ns_ = s.t_ns;
  health.last_vision_update_ns = last_vision_update_ns_;
  // Pass-through states have no covariance (NaN): unknown, which EstimatorHealth spells 0.
  health.position_sigma_m = fused_ ? s.sigma.head<3>().maxCoeff() : 0.0;

  if (!mission_ && health.estimate_valid) {
    control::PositionReference m;
    if (options_.setpoint) {
      m.p_world = options_.setpoint->head<3>();
      m.yaw_rad = (*options_.setpoint)[3];
    } else {
      m.p_world = e.p_world;
      m.yaw_rad = control::yaw_of(e.R_world_body);
    }
    mission_ = m;
  }
  const control::PositionReference mission = mission_.value_or(control::PositionReference{});
  const control::SafetyDecision d =
      supervisor_.update(now_ns, e, health, mission, controller_.hover_thrust_estimate_N());
  control::AttitudeThrustCommand command =
      d.override_command ? *d.override_command : controller_.update(e, d.reference).command;
  command = control::bound_command(command, options_.limits, controller_.hover_thrust_estimate_N())
                .command;
  watchdog_.submit(now_ns, command);
  last_reference_ = d.reference;
  r.mode = d.mode;
  r.p_ref = d.reference.p_world;
  r.yaw_ref_rad = d.reference.yaw_rad;
  output(now_ns, d.motors_off, r);
  return r;
}

std::optional<ControllerRecord> ControllerStage::on_silence(TimeNs now_ns) {
  if (!last_now_ns_) return std::nullopt;
  now_ns = std::max(now_ns, *last_now_ns_);
  last_now_ns_ = now_ns;
  ControllerRecord r;
  r.now_ns = now_ns;
  r.state_t_ns = last_state_t_ns_;
  r.input = ControllerInput::kNoState;
  r.disarmed = disarmed_;
  r.mode = supervisor_.mode();
  r.p_ref = last_reference_.p_world;
  r.yaw_ref_rad = last_reference_.yaw_rad;
  output(now_ns, disarmed_ || supervisor_.mode() == control::SafetyMode::kLanded, r);
  return r;
}

}  // namespace kestrel::pipeline
