// A closed loop on perfect state for the control tests: true state -> PositionController ->
// bound -> CommandWatchdog -> PwmMapper -> SimulatedPwmOutput -> flight-controller model ->
// dynamics; the SafetySupervisor in front of the controller. Controller at 200 Hz, flight
// controller and dynamics at 1 kHz. This is the skeleton `kestrel fly` fills with the estimator.
#pragma once

#include <cmath>
#include <functional>
#include <optional>
#include <vector>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/pwm_output.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/sim/simulated_vehicle.hpp"
#include "kestrel/sim/vehicle_imu.hpp"

namespace kestrel::test {

/// A quadrotor hovering at p with the default parameters.
inline sim::QuadrotorState hover_at(const Eigen::Vector3d& p) {
  return sim::Quadrotor::hover_state(sim::QuadrotorParameters{}, p);
}

/// A fixed position reference at p, heading yaw.
inline control::PositionReference point(const Eigen::Vector3d& p, double yaw_rad = 0.0) {
  control::PositionReference r;
  r.p_world = p;
  r.yaw_rad = yaw_rad;
  return r;
}

struct LoopSample {
  double t_s = 0.0;
  Eigen::Vector3d p_true;
  Eigen::Vector3d p_ref;
  control::SafetyMode mode = control::SafetyMode::kNominal;
  control::WatchdogState watchdog = control::WatchdogState::kActive;
  control::AttitudeThrustCommand command;
  bool crashed = false;
  bool on_ground = false;
};

struct ClosedLoop {
  sim::QuadrotorParameters vehicle_parameters;
  sim::SimulatedVehicle vehicle;
  control::PositionController controller;
  control::PwmMapper mapper;
  control::SimulatedPwmOutput output;
  control::SafetySupervisor supervisor;
  control::CommandWatchdog watchdog;
  control::CommandLimits limits;
  double control_rate_hz = 200.0;
  TimeNs t_ns = 0;

  /// The mission reference at a time (seconds).
  std::function<control::PositionReference(double)> reference = [](double) {
    return control::PositionReference{};
  };
  /// The estimator's health at a time (default: healthy, odometry up to date).
  std::function<control::EstimatorHealth(TimeNs)> health = [](TimeNs t) {
    control::EstimatorHealth h;
    h.last_vision_update_ns = t;
    return h;
  };
  /// Whether the controller runs at a time (false: the companion computer has hung).
  std::function<bool(double)> controller_alive = [](double) { return true; };
  /// A noisy IMU for the specific force the disturbance observer reads (empty: the exact
  /// specific force, as a perfect accelerometer at the centre of mass measures it).
  std::optional<sim::VehicleImuSimulator> imu;

  /// true_vehicle: the vehicle that flies where it is not the nominal one the flight
  /// controller and the position controller are set up for (a model mismatch).
  explicit ClosedLoop(const sim::QuadrotorState& initial,
                      control::PositionControllerOptions controller_options = {},
                      control::SafetyOptions safety_options = {},
                      const std::optional<sim::QuadrotorParameters>& true_vehicle = std::nullopt)
      : vehicle(true_vehicle.value_or(vehicle_parameters), {}, initial, 1000.0, vehicle_parameters),
        controller(controller_options),
        mapper(),
        output(mapper.motors_off()),
        supervisor(safety_options) {
    t_ns = initial.t_ns;
  }

  static control::VehicleStateEstimate perfect_estimate(const sim::QuadrotorState& s) {
    control::VehicleStateEstimate e;
    e.t_ns = s.t_ns;
    e.p_world = s.p_world;
    e.v_world = s.v_world;
    e.R_world_body = s.R_world_body;
    e.omega_body = s.omega_body;
    // f = R^T (a - g): the specific force an accelerometer at the centre of mass reads.
    e.specific_force_body =
        s.R_world_body.inverse() * (s.a_world + Eigen::Vector3d(0.0, 0.0, control::kGravity));
    return e;
  }

  /// The estimate: perfect, with the noisy IMU's specific force where one is set.
  control::VehicleStateEstimate estimate() {
    control::VehicleStateEstimate e = perfect_estimate(vehicle.state());
    if (imu) e.specific_force_body = imu->sample(vehicle.state()).accel_m_s2;
    return e;
  }

  /// Runs for duration_s; one sample per control step.
  std::vector<LoopSample> run(double duration_s) {
    std::vector<LoopSample> log;
    const TimeNs period_ns = s_to_ns(1.0 / control_rate_hz);
    const TimeNs end_ns = t_ns + s_to_ns(duration_s);
    control::SafetyDecision decision;
    while (t_ns < end_ns) {
      const double t_s = ns_to_s(t_ns);
      const auto estimate = this->estimate();
      if (controller_alive(t_s)) {
        const control::PositionReference mission = reference(t_s);
        decision = supervisor.update(t_ns, estimate, health(t_ns), mission,
                                     controller.hover_thrust_estimate_N());
        control::AttitudeThrustCommand command;
        if (decision.override_command) {
          command = *decision.override_command;
        } else {
          command = controller.update(estimate, decision.reference).command;
        }
        command =
            control::bound_command(command, limits, controller.hover_thrust_estimate_N()).command;
        watchdog.submit(t_ns, command);
      }
      const control::WatchdogOutput w = watchdog.output(t_ns);
      const bool motors_off = w.motors_off || decision.motors_off;
      output.write(motors_off ? mapper.motors_off() : mapper.map(w.command), t_ns);
      LoopSample s;
      s.t_s = t_s;
      s.p_true = vehicle.state().p_world;
      s.p_ref = decision.reference.p_world;
      s.mode = decision.mode;
      s.watchdog = w.state;
      s.command = w.command;
      s.crashed = vehicle.state().crashed;
      s.on_ground = vehicle.state().on_ground;
      log.push_back(s);
      vehicle.step(ns_to_s(period_ns), output.latest());
      t_ns += period_ns;
    }
    return log;
  }
};

/// Root mean square of |p_true - p_ref| over samples with t in [from_s, to_s].
inline double rms_error(const std::vector<LoopSample>& log, double from_s, double to_s = 1e9) {
  double sum = 0.0;
  int n = 0;
  for (const auto& s : log) {
    if (s.t_s < from_s || s.t_s > to_s) continue;
    sum += (s.p_true - s.p_ref).squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

}  // namespace kestrel::test
