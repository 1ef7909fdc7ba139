// Cascaded position controller (thesis 4.4: the position controller flies on the EKF's state):
// position P -> velocity PI (with feed-forward) -> acceleration -> thrust vector with gravity
// feed-forward -> tilt angles relative to the heading + collective thrust, with anti-windup,
// speed, tilt, tilt-rate and yaw-rate limits and a heading P loop.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>

#include "kestrel/control/types.hpp"

namespace kestrel::control {

struct PositionControllerOptions {
  double mass_kg = 1.2;  ///< the vehicle's mass (thrust = mass * acceleration)
  // --- position loop (P): velocity command per metre of error ---
  /// 1/s. With the velocity loop's k_v = 3 and k_i = 5 below, 1.0 (docs/flight.md, "World").
  double position_gain_xy = 1.0;
  double position_gain_z = 1.5;   ///< 1/s
  double max_speed_xy_m_s = 2.0;  ///< horizontal velocity command limit
  double max_speed_z_m_s = 1.0;   ///< vertical velocity command limit
  // --- velocity loop (PI): acceleration per m/s of error ---
  double velocity_gain_xy = 3.0;  ///< 1/s
  double velocity_gain_z = 4.0;   ///< 1/s
  /// The integral is the controller's disturbance estimate (wind, a heavier or weaker
  /// vehicle than mass_kg says) and, as the integral of k_p e_p - v, also a position spring
  /// k_i e_p: the loop's stiffness against slow disturbances is k_p k_i (position error per
  /// m/s^2 of disturbance ~ s / (k_p k_i) well below the loop's bandwidth). On perfect attitude
  /// the poles are the roots of s^3 + k_v s^2 + (k_p k_v + k_i) s + k_p k_i. k_v = 3 stays, so
  /// the tilt noise the estimate's 1-2 Hz velocity error causes stays (3.0 per m/s at 1.5 Hz).
  /// Chosen on a linear model of the loop with the flight controller's attitude loop
  /// (omega_n = sqrt(7 * 22) = 12.4 rad/s, zeta 0.89), the realistic motor lag (45 ms) and
  /// 7.5 ms of delay, as the k_p, k_i with the least Dryden gust response (docs/flight.md,
  /// "World": u and v gusts 0.59 m/s, 15 s correlation time) that neither overshoot a 1 m step
  /// more nor have less gain margin than the old k_p = 1.4, k_i = 2 (9.4 %; margin: the
  /// factor on k_v and k_i at which the model's step response diverges, 2.7x). k_p = 1.0,
  /// k_i = 5: poles -0.80 and -1.10 +- 2.24j (old: -0.59, -1.21 +- 1.83j), no overshoot, 2.9x,
  /// 18 % less gust response (k_p 0.8-1.1 with k_i 5-6 are within 1 % of it).
  double velocity_integral_gain_xy = 5.0;  ///< 1/s^2
  /// Learns the hover thrust: fast enough to catch a 28 % thrust deficit (mass +15 %, thrust
  /// constant -10 %) in about 2 s.
  double velocity_integral_gain_z = 6.0;  ///< 1/s^2
  double integral_limit_xy_m_s2 = 2.0;    ///< anti-windup clamp of the integral terms
  /// Covers that deficit (0.28 g = 2.75 m/s^2) with room for a downdraft.
  double integral_limit_z_m_s2 = 4.0;
  double max_accel_xy_m_s2 = 5.0;
  /// The learnt hover thrust as a thrust scale (docs/flight.md, "World"): a heavier vehicle or
  /// weaker rotors than mass_kg and the flight controller's throttle scale say are a shortfall
  /// of every force the rotors make, not only of the vertical one. The z integral (and the
  /// observer's d_z) learn it as the hover acceleration h = g + I_z - d_z that the nominal model
  /// must command to hold the weight; with this switch the whole commanded force is scaled by
  /// h / g, F = m (h / g) (a + g e_z) with a the command without those vertical terms, so that
  /// the tilt asks for the horizontal acceleration the loop designed. Without it the tilt is
  /// a_xy / h instead of a_xy / g: with mass +15 % and thrust -10 % (h = 1.28 g) every horizontal
  /// gain is 22 % low and the z loop's feedback gains too. In hover on the nominal vehicle
  /// h = g and nothing changes.
  bool scale_thrust_by_hover_estimate = true;
  // --- acceleration disturbance observer (docs/flight.md, "World") ---
  /// Estimates the unmodelled acceleration d = R (f_imu - (T_prev / mass_kg) e_z + D(v_body))
  /// (the IMU's specific force in the world minus what the previous thrust command and the
  /// vehicle's own drag give on the nominal model; gravity cancels) and subtracts its low-passed
  /// value from the acceleration command: the acceleration-feedback idea of INDI outer loops and of
  /// PX4's hover-thrust estimator. Catches wind, a thrust deficit or a heavier vehicle within a few
  /// time constants instead of the integral's seconds; the integral keeps what the observer cannot
  /// see (attitude errors of the estimate). Needs VehicleStateEstimate::specific_force_body.
  /// Off by default: it improves every realistic-world flight measured but costs the ideal
  /// world's hover 0.4-0.7 mm RMS (docs/flight.md, "World"); config/controller_observer.yaml
  /// switches it on.
  bool disturbance_observer = false;
  /// First-order low-pass of the raw estimate, horizontal: the 15x IMU noise of the realistic
  /// world (1.9 m/s^2 per 1 kHz sample, 0.06 m/s^2/sqrt(Hz)) reaches the tilt command as
  /// sigma = density / sqrt(4 tau) / g before the loop's own amplification; 0.4 s keeps it
  /// near the tilt noise the estimator already causes (tests/control/test_disturbance_observer).
  double observer_time_constant_xy_s = 0.4;
  /// Vertical: faster, for the realistic world's thrust deficit at the start; its noise only
  /// reaches the collective thrust.
  double observer_time_constant_z_s = 0.2;
  /// The vehicle's own body drag per unit mass, (c1 + c2 |v|) v per body axis (the default
  /// frame's 0.30 / 0.40 N s/m and 0.09 / 0.12 N s^2/m^2 over 1.2 kg), part of the nominal
  /// model, so that the observer estimates the wind's force but not the damping of the
  /// vehicle's own motion: with that in the estimate, compensated 0.4 s late, a 1 m step
  /// overshot by 14 cm instead of < 10.
  double observer_drag_xy_per_s = 0.25;
  double observer_drag_z_per_s = 0.33;
  double observer_quadratic_drag_xy_per_m = 0.075;
  double observer_quadratic_drag_z_per_m = 0.10;
  /// Scale of both velocity-integral gains while the observer is on: the observer is the fast
  /// disturbance estimate, so that the integral only has to take the slow residual; at full
  /// gain the integral winds up on the observer's first time constants and unwinds along the
  /// loop's slow pole (-0.59 /s), which is what made a step of wind take 4 s to settle.
  double observer_integral_scale = 1.0;
  double observer_limit_xy_m_s2 = 3.0;  ///< clamp of the horizontal estimate
  double observer_limit_z_m_s2 = 4.0;   ///< clamp of the vertical estimate (as the integral)
  // --- thrust and attitude limits ---
  double max_tilt_deg = 30.0;          ///< below the flight controller's 45 deg (table C.3)
  double max_tilt_rate_deg_s = 180.0;  ///< slew limit of the roll/pitch commands
  double min_thrust_N = 2.0;           ///< keeps the attitude controllable while descending
  double max_thrust_N = 24.0;          ///< below the rotors' 28 N, leaving room for attitude
  // --- heading ---
  double yaw_gain = 1.5;  ///< 1/s
  double max_yaw_rate_deg_s = 90.0;

  void validate() const;
  [[nodiscard]] std::string to_yaml() const;
  static PositionControllerOptions from_yaml(const YAML::Node& node, const std::string& source);
  /// The options at the top level or under a `controller:` key.
  static PositionControllerOptions load(const std::filesystem::path& path);

  template <typename V>
  void visit_fields(V&& v) {
    v("mass_kg", mass_kg);
    v("position_gain_xy", position_gain_xy);
    v("position_gain_z", position_gain_z);
    v("max_speed_xy_m_s", max_speed_xy_m_s);
    v("max_speed_z_m_s", max_speed_z_m_s);
    v("velocity_gain_xy", velocity_gain_xy);
    v("velocity_gain_z", velocity_gain_z);
    v("velocity_integral_gain_xy", velocity_integral_gain_xy);
    v("velocity_integral_gain_z", velocity_integral_gain_z);
    v("integral_limit_xy_m_s2", integral_limit_xy_m_s2);
    v("integral_limit_z_m_s2", integral_limit_z_m_s2);
    v("max_accel_xy_m_s2", max_accel_xy_m_s2);
    v("scale_thrust_by_hover_estimate", scale_thrust_by_hover_estimate);
    v("disturbance_observer", disturbance_observer);
    v("observer_time_constant_xy_s", observer_time_constant_xy_s);
    v("observer_time_constant_z_s", observer_time_constant_z_s);
    v("observer_drag_xy_per_s", observer_drag_xy_per_s);
    v("observer_drag_z_per_s", observer_drag_z_per_s);
    v("observer_quadratic_drag_xy_per_m", observer_quadratic_drag_xy_per_m);
    v("observer_quadratic_drag_z_per_m", observer_quadratic_drag_z_per_m);
    v("observer_integral_scale", observer_integral_scale);
    v("observer_limit_xy_m_s2", observer_limit_xy_m_s2);
    v("observer_limit_z_m_s2", observer_limit_z_m_s2);
    v("max_tilt_deg", max_tilt_deg);
    v("max_tilt_rate_deg_s", max_tilt_rate_deg_s);
    v("min_thrust_N", min_thrust_N);
    v("max_thrust_N", max_thrust_N);
    v("yaw_gain", yaw_gain);
    v("max_yaw_rate_deg_s", max_yaw_rate_deg_s);
  }
};

/// One controller step's result: the command and what limited it.
struct ControllerOutput {
  AttitudeThrustCommand command;
  Eigen::Vector3d velocity_command_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d acceleration_command_world = Eigen::Vector3d::Zero();  ///< after the limits
  Eigen::Vector3d integral_m_s2 = Eigen::Vector3d::Zero();
  /// The observer's low-passed unmodelled acceleration (zero when it is off).
  Eigen::Vector3d disturbance_m_s2 = Eigen::Vector3d::Zero();
  bool tilt_limited = false;
  bool thrust_limited = false;
  bool speed_limited = false;
};

class PositionController {
 public:
  explicit PositionController(PositionControllerOptions options = {});

  /// One step at the estimate's time t_ns; dt is the time since the previous step (the first
  /// step, a step backwards in time, or one after more than 0.5 s does not integrate).
  ControllerOutput update(const VehicleStateEstimate& estimate, const PositionReference& reference);

  /// Forgets the integrators and the command history (e.g. on the ground, before take-off).
  void reset();
  /// The thrust that holds the vehicle in hover as learnt by the z integrator and the
  /// observer: m (g + I_z - d_z).
  [[nodiscard]] double hover_thrust_estimate_N() const;
  [[nodiscard]] const PositionControllerOptions& options() const { return options_; }
  /// The observer's current estimate of the unmodelled acceleration (world, m/s^2).
  [[nodiscard]] const Eigen::Vector3d& disturbance_estimate_m_s2() const { return disturbance_; }

 private:
  /// Updates the disturbance estimate from the estimate's specific force (see the options).
  void observe(const VehicleStateEstimate& estimate, double dt);
  /// h = g + I_z - d_z, the hover acceleration learnt by the z integrator and the observer.
  [[nodiscard]] double hover_acceleration() const;
  /// h / g (hover_acceleration); 1 when the scale is off.
  [[nodiscard]] double thrust_scale_of_hover() const;
  /// The thrust vector for the acceleration command, within the tilt and thrust limits.
  struct Thrust {
    Eigen::Vector3d F = Eigen::Vector3d::Zero();  ///< world, N
    double magnitude_N = 0.0;
    double scale = 1.0;  ///< thrust_scale_of_hover() it was made with
  };
  [[nodiscard]] Thrust thrust_for(const Eigen::Vector3d& a_cmd, ControllerOutput& out) const;
  /// The velocity integral's step with conditional anti-windup.
  void integrate(const Eigen::Vector3d& e_v, const Thrust& thrust, bool accel_limited,
                 const ControllerOutput& out, double dt);

  PositionControllerOptions options_;
  Eigen::Vector3d integral_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d disturbance_ = Eigen::Vector3d::Zero();
  std::optional<double> last_thrust_N_;  // the previous step's thrust command
  double last_thrust_scale_ = 1.0;       // and the thrust scale it was made with
  std::optional<TimeNs> last_t_ns_;
  double last_roll_ = 0.0;
  double last_pitch_ = 0.0;
};

}  // namespace kestrel::control
