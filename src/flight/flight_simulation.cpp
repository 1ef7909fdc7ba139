// The closed-loop flight: one simulated-time loop over the vehicle, its sensors and the
// on-board software.
#include "kestrel/flight/flight_simulation.hpp"

#include <chrono>
#include <cmath>
#include <deque>
#include <sstream>
#include <stdexcept>

#include "kestrel/control/pwm_output.hpp"
#include "kestrel/flight/imu_forward_predictor.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/simulated_vehicle.hpp"
#include "kestrel/sim/vehicle_imu.hpp"

namespace kestrel::flight {
namespace {

/// A measurement on its way from the camera to the filter.
struct InFlight {
  TimeNs arrives_ns = 0;
  fusion::RelativePoseMeasurement measurement;
};

bool is_multiple(double big, double small) {
  const double ratio = big / small;
  return std::abs(ratio - std::round(ratio)) < 1e-9 && std::round(ratio) >= 1.0;
}

double rms_over(const FlightResult& r, const std::function<double(const FlightSample&)>& f) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const FlightSample& s : r.samples) {
    if (s.t_s < r.settle_s) continue;
    const double e = f(s);
    sum += e * e;
    ++n;
  }
  return n == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(n));
}

}  // namespace

FlightOptions::FlightOptions() : imu_noise(sim::default_vehicle_imu_noise()) {}

void FlightOptions::validate() const {
  if (!(physics_rate_hz > 0.0) || !(control_rate_hz > 0.0) || !(camera_rate_hz > 0.0)) {
    throw std::invalid_argument("flight: rates must be positive");
  }
  if (!is_multiple(physics_rate_hz, control_rate_hz)) {
    throw std::invalid_argument("flight: physics_rate_hz must be a multiple of control_rate_hz");
  }
  if (camera_rate_hz > physics_rate_hz) {
    throw std::invalid_argument("flight: camera_rate_hz exceeds physics_rate_hz");
  }
  if (!(vision_latency_s >= 0.0) || vision_latency_s > 1.0) {
    throw std::invalid_argument("flight: vision_latency_s must be in [0, 1] s");
  }
  if (!(vo_off_for_s >= 0.0)) throw std::invalid_argument("flight: vo_off_for_s must be >= 0");
  vision.validate();
  fusion.validate();
  safety.validate();
}

std::string FlightCounters::describe() const {
  std::ostringstream os;
  const double n = frames > 0 ? static_cast<double>(frames) : 1.0;
  os << "frames " << frames << " (tracked " << frames_tracked << ", odometry off " << frames_off
     << "), mean depth fill " << 100.0 * depth_fill_sum / n << " %, per frame: render "
     << render_ms / n << " ms, stereo " << match_ms / n << " ms, odometry " << track_ms / n
     << " ms; fusion " << fusion.describe();
  return os.str();
}

double FlightResult::rms_tracking_m() const {
  return rms_over(*this, [](const FlightSample& s) { return (s.p_true - s.p_ref).norm(); });
}

double FlightResult::rms_estimate_m() const {
  return rms_over(*this, [](const FlightSample& s) { return (s.p_est - s.p_true).norm(); });
}

double FlightResult::max_tracking_m() const {
  double m = 0.0;
  for (const FlightSample& s : samples) {
    if (s.t_s >= settle_s) m = std::max(m, (s.p_true - s.p_ref).norm());
  }
  return m;
}

FlightSimulation::FlightSimulation(Scenario scenario, FlightOptions options)
    : scenario_(std::move(scenario)), options_(std::move(options)) {
  options_.fusion.set_imu_noise(options_.imu_noise);
  options_.fusion.T_body_cam = options_.vision.T_body_cam;
  options_.fusion.reorder_window_s =
      std::max(options_.fusion.reorder_window_s, options_.vision_latency_s + 0.010);
  options_.validate();
}

FlightResult FlightSimulation::run(double duration_s,
                                   const std::function<void(const FlightSample&)>& progress) {
  if (!(duration_s > 0.0)) throw std::invalid_argument("flight: duration must be positive");
  const auto wall_start = std::chrono::steady_clock::now();
  const FlightOptions& o = options_;
  const sim::Scene scene = sim::make_scene(scenario_.scene, o.seed);
  const SE3 T_world_start = scene.T_world_start();

  // The vehicle, hovering at the start pose, and its sensors.
  const double dt_s = 1.0 / o.physics_rate_hz;
  const TimeNs dt_ns = s_to_ns(dt_s);
  sim::SimulatedVehicle vehicle(
      o.vehicle, o.flight_controller,
      sim::Quadrotor::hover_state(o.vehicle, T_world_start.translation(),
                                  control::yaw_of(T_world_start.so3())),
      o.physics_rate_hz);
  sim::VehicleImuSimulator imu(o.imu_noise, o.seed);
  StereoVision vision(scene, o.vision, o.seed);

  // The on-board software. The filter starts at the known take-off pose (the world frame is
  // defined there), at rest, with zero bias estimates.
  fusion::FusionEngine fusion(o.fusion);
  fusion::NominalState initial;
  initial.t_ns = 0;
  initial.p_world = vehicle.state().p_world;
  initial.q_world_body = vehicle.state().R_world_body.unit_quaternion();
  fusion.initialize(initial);
  ImuForwardPredictor predictor(control::kGravity);
  {
    fusion::FusedState start;
    start.state = initial;
    predictor.set_fused(start);
  }
  control::PositionController controller(o.controller);
  control::PwmMapper mapper(o.pwm);
  control::SimulatedPwmOutput output(mapper.motors_off());
  control::SafetySupervisor supervisor(o.safety);
  control::CommandWatchdog watchdog(o.watchdog);

  FlightResult result;
  result.scenario = scenario_.name;
  result.settle_s = scenario_.settle_s;
  const auto control_every =
      static_cast<std::int64_t>(std::llround(o.physics_rate_hz / o.control_rate_hz));
  const auto ticks = static_cast<std::int64_t>(std::llround(duration_s * o.physics_rate_hz));
  result.samples.reserve(static_cast<std::size_t>(ticks / control_every + 1));
  const double camera_period_s = 1.0 / o.camera_rate_hz;
  std::int64_t next_frame = 0;  // index of the next camera frame
  std::deque<InFlight> in_flight;
  TimeNs last_vision_update_ns = 0;
  bool vo_ok = false;
  double position_sigma = 0.0;
  control::SafetyDecision decision;
  std::optional<TimeNs> crash_ns;

  for (std::int64_t tick = 0; tick <= ticks; ++tick) {
    const TimeNs t_ns = tick * dt_ns;
    const double t_s = ns_to_s(t_ns);
    const sim::QuadrotorState& truth = vehicle.state();

    // Sensors: the IMU every tick, the cameras at their rate.
    const io::ImuSample sample = imu.sample(truth);
    fusion.add_imu(sample);
    predictor.add_imu(sample);
    if (t_s + 1e-9 >= static_cast<double>(next_frame) * camera_period_s) {
      ++next_frame;
      const bool off = o.vo_off_at_s >= 0.0 && t_s >= o.vo_off_at_s &&
                       t_s < o.vo_off_at_s + o.vo_off_for_s;
      if (off) {
        ++result.counters.frames_off;
        vo_ok = false;
      } else {
        const VisionFrame frame = vision.process(t_ns, SE3(truth.R_world_body, truth.p_world));
        ++result.counters.frames;
        result.counters.depth_fill_sum += frame.depth_fill;
        result.counters.render_ms += frame.render_ms;
        result.counters.match_ms += frame.match_ms;
        result.counters.track_ms += frame.track_ms;
        vo_ok = frame.track.ok();
        if (vo_ok) ++result.counters.frames_tracked;
        if (frame.measurement) {
          in_flight.push_back({t_ns + s_to_ns(o.vision_latency_s), *frame.measurement});
        }
      }
    }
    while (!in_flight.empty() && in_flight.front().arrives_ns <= t_ns) {
      fusion.add_relative_pose(in_flight.front().measurement);
      in_flight.pop_front();
    }

    // On-board control at its rate.
    if (tick % control_every == 0) {
      for (const fusion::FusedState& f : fusion.poll(true)) {
        if ((f.flags & fusion::kFlagUpdated) != 0U) last_vision_update_ns = f.t_ns;
        position_sigma = f.sigma.head<3>().maxCoeff();
        predictor.set_fused(f);
      }
      const auto estimate = predictor.predict();
      control::EstimatorHealth health;
      health.estimate_valid = estimate.has_value() && estimate->p_world.allFinite() &&
                              estimate->v_world.allFinite();
      health.last_vision_update_ns = last_vision_update_ns;
      health.position_sigma_m = position_sigma;
      control::VehicleStateEstimate e = estimate.value_or(control::VehicleStateEstimate{});
      e.t_ns = t_ns;
      decision = supervisor.update(t_ns, e, health, scenario_.path.at(t_s),
                                   controller.hover_thrust_estimate_N());
      control::AttitudeThrustCommand command =
          decision.override_command ? *decision.override_command
                                    : controller.update(e, decision.reference).command;
      command = control::bound_command(command, o.limits, controller.hover_thrust_estimate_N())
                    .command;
      watchdog.submit(t_ns, command);
      const control::WatchdogOutput w = watchdog.output(t_ns);
      const bool motors_off = w.motors_off || decision.motors_off;
      output.write(motors_off ? mapper.motors_off() : mapper.map(w.command), t_ns);

      FlightSample s;
      s.t_s = t_s;
      s.p_true = truth.p_world;
      s.p_ref = decision.reference.p_world;
      s.p_est = e.p_world;
      s.vo_ok = vo_ok;
      s.mode = decision.mode;
      s.position_sigma_m = position_sigma;
      s.command = w.command;
      s.crashed = truth.crashed;
      result.samples.push_back(s);
      if (progress && tick % static_cast<std::int64_t>(std::llround(o.physics_rate_hz)) == 0) {
        progress(s);
      }
    }
    if (truth.crashed && !crash_ns) crash_ns = t_ns;
    if (crash_ns && t_ns - *crash_ns > s_to_ns(1.0)) break;
    vehicle.step(dt_s, output.latest());
  }

  result.crashed = crash_ns.has_value();
  result.duration_s = result.samples.empty() ? 0.0 : result.samples.back().t_s;
  result.final_mode = std::string(control::to_string(supervisor.mode()));
  result.counters.fusion = fusion.counters();
  result.counters.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace kestrel::flight
