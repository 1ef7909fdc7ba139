// The closed-loop flight: one simulated-time loop over the vehicle, its sensors and the
// on-board software.
#include "kestrel/flight/flight_simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <iterator>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "kestrel/control/pwm_output.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/flight/imu_forward_predictor.hpp"
#include "kestrel/flight/mission_clock.hpp"
#include "kestrel/sim/camera_link.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/simulated_vehicle.hpp"
#include "kestrel/sim/vehicle_imu.hpp"
#include "kestrel/sim/wind.hpp"

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
    if (s.t_s < r.settle_s || s.mode == control::SafetyMode::kLanded) continue;
    const double e = f(s);
    sum += e * e;
    ++n;
  }
  return n == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(n));
}

/// The estimate the controller flies on and the estimator's health for the supervisor.
struct EstimatorOutput {
  control::VehicleStateEstimate estimate;
  control::EstimatorHealth health;
};

/// Every component of the closed loop, with the state carried from one tick to the next.
/// Declaration order is construction order: output_ starts from mapper_'s motors-off channels.
class FlightLoop {
 public:
  FlightLoop(const sim::Scene& scene, const FlightOptions& options, const Scenario& scenario);

  [[nodiscard]] const sim::QuadrotorState& truth() const { return vehicle_.state(); }
  /// This tick's IMU sample, the camera frame if one is due, and the measurements that have
  /// reached the filter by t_ns.
  void sense(TimeNs t_ns, double t_s);
  /// One on-board control step: estimate, safety, position control, command to the motors.
  FlightSample control_step(TimeNs t_ns, double t_s);
  void step_vehicle(double dt_s) {
    const sim::QuadrotorState& s = vehicle_.state();
    vehicle_.quadrotor().set_wind_world(wind_.step(dt_s, s.p_world, s.v_world));
    vehicle_.step(dt_s, output_.latest());
  }

  [[nodiscard]] control::SafetyMode mode() const { return supervisor_.mode(); }
  /// The frame counters and the filter's.
  [[nodiscard]] FlightCounters counters() const;
  [[nodiscard]] const std::vector<RelocalizationEvent>& relocalizations() const {
    return relocalizations_;
  }
  [[nodiscard]] const std::vector<OdometryCheck>& odometry_checks() const {
    return odometry_checks_;
  }

 private:
  void start_estimator();
  void camera_frame(TimeNs t_ns, double t_s);
  void check_odometry(const VisionFrame& frame, double t_s, const SE3& T_world_cam_true);
  EstimatorOutput estimate(TimeNs t_ns);

  const FlightOptions& options_;
  const Scenario& scenario_;
  sim::SimulatedVehicle vehicle_;
  sim::WindModel wind_;
  sim::CameraLink link_;
  sim::VehicleImuSimulator imu_;
  StereoVision vision_;
  fusion::FusionEngine fusion_;
  ImuForwardPredictor predictor_;
  control::PositionController controller_;
  control::PwmMapper mapper_;
  control::SimulatedPwmOutput output_;
  control::SafetySupervisor supervisor_;
  control::CommandWatchdog watchdog_;

  double camera_period_s_;
  std::int64_t next_frame_ = 0;  // index of the next camera frame
  MissionClock mission_clock_;   // eases to a stop in the supervisor's holds
  std::deque<InFlight> in_flight_;
  bool vo_ok_ = false;
  TimeNs last_vision_update_ns_ = 0;
  double position_sigma_m_ = 0.0;
  fusion::FusedState last_fused_;
  FlightCounters counters_;
  // The true camera pose of every frame since the current reference, in stamp order (the stamps
  // rise: no per-frame node allocations): each measurement's and relocalisation's error is known
  // here. Older frames are dropped as the reference moves on (measurements only go back to it).
  std::deque<std::pair<TimeNs, SE3>> true_poses_;
  [[nodiscard]] const SE3* true_pose(TimeNs stamp_ns) const;
  std::vector<RelocalizationEvent> relocalizations_;
  std::vector<OdometryCheck> odometry_checks_;
};

/// The vehicle hovers at the scenario's start (or stands there on the floor, rotors at hover
/// speed: the ground contact holds it until the thrust exceeds the weight).
FlightLoop::FlightLoop(const sim::Scene& scene, const FlightOptions& options,
                       const Scenario& scenario)
    : options_(options),
      scenario_(scenario),
      // The true vehicle starts hovering (its own hover rotor speed) or standing where the
      // scenario starts; the flight controller is set up for the nominal one.
      vehicle_(
          options.world.vehicle_mismatch.true_vehicle(options.vehicle), options.flight_controller,
          sim::Quadrotor::hover_state(options.world.vehicle_mismatch.true_vehicle(options.vehicle),
                                      scenario.start_world, scenario.path.at(0.0).yaw_rad),
          options.physics_rate_hz, options.vehicle),
      wind_(options.world.wind, options.seed),
      link_(options.world.camera.drop_probability, options.world.camera.latency_jitter_s,
            options.seed),
      imu_(options.imu_noise, options.seed),
      vision_(scene, options.vision, options.seed),
      fusion_(options.fusion),
      predictor_(control::kGravity),
      controller_(options.controller),
      mapper_(options.pwm),
      output_(mapper_.motors_off()),
      supervisor_(options.safety),
      watchdog_(options.watchdog),
      camera_period_s_(1.0 / options.camera_rate_hz),
      mission_clock_(options.mission_ease_time_s) {
  const sim::ImuWorldOptions& w = options.world.imu;
  if (w.warm_up_gyro_drift_rad_s > 0.0 || w.warm_up_accel_drift_m_s2 > 0.0) {
    imu_.set_warm_up_drift(w.warm_up_gyro_drift_rad_s, w.warm_up_accel_drift_m_s2,
                           w.warm_up_time_constant_s);
  }
  vision_.set_exposure(options.world.camera.exposure());
  start_estimator();
}

// The filter starts at the known take-off pose (the world frame is defined there), at rest,
// with zero bias estimates.
void FlightLoop::start_estimator() {
  fusion::NominalState initial;
  initial.t_ns = 0;
  initial.p_world = vehicle_.state().p_world;
  initial.q_world_body = vehicle_.state().R_world_body.unit_quaternion();
  fusion_.initialize(initial);
  fusion::FusedState start;
  start.state = initial;
  predictor_.set_fused(start);
}

void FlightLoop::sense(TimeNs t_ns, double t_s) {
  const io::ImuSample sample = imu_.sample(vehicle_.state());
  fusion_.add_imu(sample);
  predictor_.add_imu(sample);
  if (t_s + 1e-9 >= static_cast<double>(next_frame_) * camera_period_s_) {
    ++next_frame_;
    camera_frame(t_ns, t_s);
  }
  // in_flight_ is sorted by arrival: with jitter a frame may overtake the one before it.
  while (!in_flight_.empty() && in_flight_.front().arrives_ns <= t_ns) {
    fusion_.add_relative_pose(in_flight_.front().measurement);
    in_flight_.pop_front();
  }
}

// The measurement against the true motion since its reference frame, and the frames before that
// reference forgotten (no later measurement goes back further; a relocalisation's reference is
// the current one).
void FlightLoop::check_odometry(const VisionFrame& frame, double t_s, const SE3& T_world_cam_true) {
  if (!frame.measurement) return;
  const fusion::RelativePoseMeasurement& m = *frame.measurement;
  const SE3* ref = true_pose(m.t_ref_ns);
  if (m.t_ref_ns != m.t_ns && ref != nullptr && m.covariance.allFinite()) {
    const SE3 T_true = ref->inverse() * T_world_cam_true;
    OdometryCheck c;
    c.t_s = t_s;
    c.t_ref_s = t_s - ns_to_s(m.t_ns - m.t_ref_ns);
    c.translation_true = T_true.translation();
    c.translation_measured = m.T_ref_cur.translation();
    c.rotation_error_deg = (T_true.so3().inverse() * m.T_ref_cur.so3()).log() * kRadToDeg;
    const Eigen::Matrix<double, 6, 1> sigma = m.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    c.sigma_translation = sigma.head<3>();
    c.sigma_rotation_deg = sigma.tail<3>() * kRadToDeg;
    c.geometric_fallback = frame.track.geometric_fallback;
    c.new_reference = m.starts_new_reference;
    c.relocalised = frame.relocalization && frame.relocalization->ok();
    odometry_checks_.push_back(c);
  }
  // The reference of the next measurements: this frame if it starts one, else m's.
  const TimeNs keep_from = m.starts_new_reference ? m.t_ns : m.t_ref_ns;
  while (!true_poses_.empty() && true_poses_.front().first < keep_from) true_poses_.pop_front();
}

// The true pose of the frame stamped `stamp_ns`, or null where it is no longer (or never was)
// kept.
const SE3* FlightLoop::true_pose(TimeNs stamp_ns) const {
  const auto it =
      std::lower_bound(true_poses_.begin(), true_poses_.end(), stamp_ns,
                       [](const std::pair<TimeNs, SE3>& p, TimeNs t) { return p.first < t; });
  return it != true_poses_.end() && it->first == stamp_ns ? &it->second : nullptr;
}

// The frame is rendered from the true pose (with the world's blur and rolling shutter), is
// stamped t - t_d on the IMU clock (the true camera-IMU offset, unknown to the filter), and
// its measurement reaches the filter after the vision latency (with the world's jitter) unless
// the frame is lost on the way.
void FlightLoop::camera_frame(TimeNs t_ns, double t_s) {
  const bool off = options_.vo_off_at_s >= 0.0 && t_s >= options_.vo_off_at_s &&
                   t_s < options_.vo_off_at_s + options_.vo_off_for_s;
  if (off) {
    ++counters_.frames_off;
    vo_ok_ = false;
    return;
  }
  if (link_.drop()) {
    ++counters_.frames_dropped;
    return;
  }
  const sim::QuadrotorState& truth = vehicle_.state();
  const BodyTwist twist{truth.v_world, truth.omega_body};
  const TimeNs stamp_ns = t_ns - s_to_ns(options_.world.imu.camera_time_offset_s);
  // The on-board estimate at the frame (the filter's, carried to now by the IMU): the
  // relocalisation's prior after a gap, so not needed without relocalisation.
  std::optional<PoseEstimate> estimate;
  if (const auto e = options_.vision.relocalize_after_gap ? predictor_.predict() : std::nullopt;
      e && control::finite_estimate(*e)) {
    estimate = PoseEstimate{SE3(e->R_world_body, e->p_world), position_sigma_m_};
  }
  const VisionFrame frame = vision_.process(stamp_ns, SE3(truth.R_world_body, truth.p_world),
                                            &twist, estimate ? &*estimate : nullptr);
  ++counters_.frames;
  counters_.expose_ms += frame.expose_ms;
  counters_.depth_fill_sum += frame.depth_fill;
  counters_.render_ms += frame.render_ms;
  counters_.match_ms += frame.match_ms;
  counters_.track_ms += frame.track_ms;
  vo_ok_ = frame.track.ok();
  if (vo_ok_) ++counters_.frames_tracked;
  const SE3 T_world_cam_true = SE3(truth.R_world_body, truth.p_world) * options_.vision.T_body_cam;
  if (frame.relocalization) {
    RelocalizationEvent e;
    e.t_s = t_s;
    e.result = *frame.relocalization;
    e.ms = frame.relocalization_ms;
    if (const SE3* ref = true_pose(frame.relocalization_reference_ns); ref != nullptr) {
      const SE3 T_true = ref->inverse() * T_world_cam_true;
      const SE3 T_est = e.result.ok() ? e.result.T_ref_cur : e.result.T_ref_cur_pnp;
      const SE3 d = T_true.inverse() * T_est;
      e.translation_error_m = d.translation().norm();
      e.rotation_error_deg = d.so3().angle() * kRadToDeg;
    }
    relocalizations_.push_back(e);
  }
  true_poses_.emplace_back(stamp_ns, T_world_cam_true);
  check_odometry(frame, t_s, T_world_cam_true);
  if (frame.measurement) {
    const InFlight m{t_ns + s_to_ns(link_.latency_s(options_.vision_latency_s)),
                     *frame.measurement};
    auto at = in_flight_.end();
    while (at != in_flight_.begin() && std::prev(at)->arrives_ns > m.arrives_ns) --at;
    in_flight_.insert(at, m);
  }
}

// The filter's new outputs, carried to t_ns by the IMU.
EstimatorOutput FlightLoop::estimate(TimeNs t_ns) {
  for (const fusion::FusedState& f : fusion_.poll(true)) {
    if ((f.flags & fusion::kFlagUpdated) != 0U) last_vision_update_ns_ = f.t_ns;
    position_sigma_m_ = f.sigma.head<3>().maxCoeff();
    last_fused_ = f;
    predictor_.set_fused(f);
  }
  const auto predicted = predictor_.predict();
  EstimatorOutput out;
  out.health.estimate_valid =
      predicted.has_value() && predicted->p_world.allFinite() && predicted->v_world.allFinite();
  out.health.last_vision_update_ns = last_vision_update_ns_;
  out.health.position_sigma_m = position_sigma_m_;
  out.estimate = predicted.value_or(control::VehicleStateEstimate{});
  out.estimate.t_ns = t_ns;
  return out;
}

FlightSample FlightLoop::control_step(TimeNs t_ns, double t_s) {
  const auto [e, health] = estimate(t_ns);
  // The supervisor's mode of the previous step: the mission's clock eases to a stop in a hold
  // and the hold flies it (SafetyOptions::hold_flies_mission), then eases back.
  mission_clock_.advance(
      t_s, !options_.pause_mission_in_hold || supervisor_.mode() == control::SafetyMode::kNominal);
  const control::SafetyDecision decision =
      supervisor_.update(t_ns, e, health, mission_clock_.reference(scenario_.path),
                         controller_.hover_thrust_estimate_N());
  control::AttitudeThrustCommand command = decision.override_command
                                               ? *decision.override_command
                                               : controller_.update(e, decision.reference).command;
  command = control::bound_command(command, options_.limits, controller_.hover_thrust_estimate_N())
                .command;
  watchdog_.submit(t_ns, command);
  const control::WatchdogOutput w = watchdog_.output(t_ns);
  const bool motors_off = w.motors_off || decision.motors_off;
  output_.write(motors_off ? mapper_.motors_off() : mapper_.map(w.command), t_ns);

  const sim::QuadrotorState& truth = vehicle_.state();
  FlightSample s;
  s.t_s = t_s;
  s.p_true = truth.p_world;
  s.p_ref = decision.reference.p_world;
  s.p_est = e.p_world;
  s.vo_ok = vo_ok_;
  s.mode = decision.mode;
  s.position_sigma_m = position_sigma_m_;
  s.command = w.command;
  s.crashed = truth.crashed;
  s.v_true = truth.v_world;
  s.v_est = e.v_world;
  s.attitude_error_rad = (e.R_world_body * truth.R_world_body.inverse()).log();
  s.accel_bias_est = last_fused_.state.accel_bias_m_s2;
  s.accel_bias_true = imu_.accel_bias() + imu_.accel_drift(t_ns);
  s.sigma_p_theta_v = last_fused_.sigma;
  return s;
}

FlightCounters FlightLoop::counters() const {
  FlightCounters c = counters_;
  c.fusion = fusion_.counters();
  c.relocalizations_tried = relocalizations_.size();
  c.relocalizations_ok = static_cast<std::size_t>(
      std::count_if(relocalizations_.begin(), relocalizations_.end(),
                    [](const RelocalizationEvent& e) { return e.result.ok(); }));
  return c;
}

}  // namespace

FlightOptions::FlightOptions() : imu_noise(sim::default_vehicle_imu_noise()) {
  fusion.adaptive_vo_noise.enabled = true;
}

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
  if (!(mission_ease_time_s > 0.0) || mission_ease_time_s > 10.0) {
    throw std::invalid_argument("flight: mission_ease_time_s must be in (0, 10] s");
  }
  world.validate();
  vision.validate();
  fusion.validate();
  safety.validate();
}

std::string FlightCounters::describe() const {
  std::ostringstream os;
  const double n = frames > 0 ? static_cast<double>(frames) : 1.0;
  os << "frames " << frames << " (tracked " << frames_tracked << ", odometry off " << frames_off
     << ", dropped " << frames_dropped << "), mean depth fill " << 100.0 * depth_fill_sum / n
     << " %, relocalised after a gap " << relocalizations_ok << " of " << relocalizations_tried
     << ", per frame: render " << render_ms / n << " ms (blur and shutter " << expose_ms / n
     << " ms), stereo " << match_ms / n << " ms, odometry " << track_ms / n << " ms; fusion "
     << fusion.describe();
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
    if (s.t_s >= settle_s && s.mode != control::SafetyMode::kLanded) {
      m = std::max(m, (s.p_true - s.p_ref).norm());
    }
  }
  return m;
}

FlightSimulation::FlightSimulation(Scenario scenario, FlightOptions options)
    : scenario_(std::move(scenario)), options_(std::move(options)) {
  // The simulated IMU draws exactly these densities: the filter keeps its own inflation (none
  // unless the fusion options set one), not the in-flight factor set_imu_noise() gives a real
  // IMU's sensor file.
  // The world's IMU: its in-flight densities are the simulated ones and the filter's (a real
  // filter reads the data sheet's from the sensor file and applies the same in-flight factor).
  options_.validate();
  const sim::ImuWorldOptions& w = options_.world.imu;
  options_.imu_noise.gyro_noise_density *= w.white_noise_scale;
  options_.imu_noise.accel_noise_density *= w.white_noise_scale;
  options_.imu_noise.gyro_random_walk *= w.bias_random_walk_scale;
  options_.imu_noise.accel_random_walk *= w.bias_random_walk_scale;
  const double inflation = options_.fusion.imu_noise_inflation;
  options_.fusion.set_imu_noise(options_.imu_noise);
  options_.fusion.imu_noise_inflation = inflation;
  options_.fusion.T_body_cam = options_.vision.T_body_cam;
  // The hold flies the mission that the eased clock brings to rest.
  options_.safety.hold_flies_mission = options_.pause_mission_in_hold;
  // The filter must hold its inputs until the latest measurement has arrived: the longest
  // latency, plus the stamp's offset from the exposure (the designer knows neither exactly,
  // so 10 ms of margin).
  const double longest_s = options_.vision_latency_s + options_.world.camera.latency_jitter_s +
                           std::max(0.0, options_.world.imu.camera_time_offset_s);
  options_.fusion.reorder_window_s = std::max(options_.fusion.reorder_window_s, longest_s + 0.010);
  // A mission that starts standing on the floor defines where the body origin rests: the
  // vehicle's ground contact and the supervisor's landing detection use that height.
  if (scenario_.starts_on_ground) {
    options_.vehicle.ground_z_m = scenario_.start_world.z();
    options_.safety.ground_z_m = scenario_.start_world.z();
  }
  options_.validate();
}

FlightResult FlightSimulation::run(double duration_s,
                                   const std::function<void(const FlightSample&)>& progress,
                                   const std::atomic<bool>* stop) {
  if (!(duration_s > 0.0)) throw std::invalid_argument("flight: duration must be positive");
  const auto wall_start = std::chrono::steady_clock::now();
  const FlightOptions& o = options_;
  const sim::Scene scene = sim::make_scene(scenario_.scene, o.seed);
  FlightLoop loop(scene, o, scenario_);

  FlightResult result;
  result.scenario = scenario_.name;
  result.settle_s = scenario_.settle_s;
  const double dt_s = 1.0 / o.physics_rate_hz;
  const TimeNs dt_ns = s_to_ns(dt_s);
  const auto control_every =
      static_cast<std::int64_t>(std::llround(o.physics_rate_hz / o.control_rate_hz));
  const auto progress_every = static_cast<std::int64_t>(std::llround(o.physics_rate_hz));
  const auto ticks = static_cast<std::int64_t>(std::llround(duration_s * o.physics_rate_hz));
  result.samples.reserve(static_cast<std::size_t>(ticks / control_every + 1));
  std::optional<TimeNs> crash_ns;
  for (std::int64_t tick = 0; tick <= ticks; ++tick) {
    const TimeNs t_ns = tick * dt_ns;
    const double t_s = ns_to_s(t_ns);
    loop.sense(t_ns, t_s);
    if (tick % control_every == 0) {
      result.samples.push_back(loop.control_step(t_ns, t_s));
      if (progress && tick % progress_every == 0) progress(result.samples.back());
      if (stop != nullptr && stop->load()) {
        result.interrupted = true;
        break;
      }
    }
    if (loop.truth().crashed && !crash_ns) crash_ns = t_ns;
    if (crash_ns && t_ns - *crash_ns > s_to_ns(1.0)) break;
    loop.step_vehicle(dt_s);
  }

  result.crashed = crash_ns.has_value();
  result.duration_s = result.samples.empty() ? 0.0 : result.samples.back().t_s;
  result.final_mode = std::string(control::to_string(loop.mode()));
  result.counters = loop.counters();
  result.relocalizations = loop.relocalizations();
  result.odometry_checks = loop.odometry_checks();
  result.counters.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace kestrel::flight
