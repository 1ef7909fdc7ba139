// Cascaded P / PI position controller with gravity feed-forward and limits.
#include "kestrel/control/position_controller.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::control {

namespace {

// Scales the horizontal part of v to at most `limit`; true if it did.
bool limit_horizontal(Eigen::Vector3d& v, double limit) {
  const double n = v.head<2>().norm();
  if (n <= limit) return false;
  v.head<2>() *= limit / n;
  return true;
}
}  // namespace

double wrap_angle(double rad) {
  const double two_pi = 2.0 * std::numbers::pi;
  double r = std::fmod(rad + std::numbers::pi, two_pi);
  if (r <= 0.0) r += two_pi;
  return r - std::numbers::pi;
}

double yaw_of(const SO3& R_world_body) {
  const Eigen::Vector3d x = R_world_body * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

void PositionControllerOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw InputError("controller option '" + field + "': " + why);
  };
  auto pos = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0)) fail(name, "must be positive and finite");
  };
  auto nonneg = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v >= 0.0)) fail(name, "must be >= 0 and finite");
  };
  pos("mass_kg", mass_kg);
  pos("position_gain_xy", position_gain_xy);
  pos("position_gain_z", position_gain_z);
  pos("max_speed_xy_m_s", max_speed_xy_m_s);
  pos("max_speed_z_m_s", max_speed_z_m_s);
  pos("velocity_gain_xy", velocity_gain_xy);
  pos("velocity_gain_z", velocity_gain_z);
  nonneg("velocity_integral_gain_xy", velocity_integral_gain_xy);
  nonneg("velocity_integral_gain_z", velocity_integral_gain_z);
  nonneg("integral_limit_xy_m_s2", integral_limit_xy_m_s2);
  nonneg("integral_limit_z_m_s2", integral_limit_z_m_s2);
  pos("max_accel_xy_m_s2", max_accel_xy_m_s2);
  pos("observer_time_constant_xy_s", observer_time_constant_xy_s);
  pos("observer_time_constant_z_s", observer_time_constant_z_s);
  nonneg("observer_drag_xy_per_s", observer_drag_xy_per_s);
  nonneg("observer_drag_z_per_s", observer_drag_z_per_s);
  nonneg("observer_quadratic_drag_xy_per_m", observer_quadratic_drag_xy_per_m);
  nonneg("observer_quadratic_drag_z_per_m", observer_quadratic_drag_z_per_m);
  nonneg("observer_integral_scale", observer_integral_scale);
  if (observer_integral_scale > 1.0) fail("observer_integral_scale", "must be at most 1");
  nonneg("observer_limit_xy_m_s2", observer_limit_xy_m_s2);
  nonneg("observer_limit_z_m_s2", observer_limit_z_m_s2);
  pos("max_tilt_deg", max_tilt_deg);
  if (max_tilt_deg >= 89.0) fail("max_tilt_deg", "must be below 89");
  pos("max_tilt_rate_deg_s", max_tilt_rate_deg_s);
  pos("min_thrust_N", min_thrust_N);
  pos("max_thrust_N", max_thrust_N);
  if (max_thrust_N <= mass_kg * kGravity)
    fail("max_thrust_N", "must exceed the weight mass_kg * g");
  if (min_thrust_N >= mass_kg * kGravity)
    fail("min_thrust_N", "must be below the weight mass_kg * g");
  nonneg("yaw_gain", yaw_gain);
  pos("max_yaw_rate_deg_s", max_yaw_rate_deg_s);
}

std::string PositionControllerOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

PositionControllerOptions PositionControllerOptions::from_yaml(const YAML::Node& node,
                                                               const std::string& source) {
  PositionControllerOptions o;
  io::option_fields::read_fields(node, source, "controller", o);
  o.validate();
  return o;
}

PositionControllerOptions PositionControllerOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["controller"]) return from_yaml(root["controller"], path.string());
  return from_yaml(root, path.string());
}

PositionController::PositionController(PositionControllerOptions options)
    : options_(std::move(options)) {
  options_.validate();
}

void PositionController::reset() {
  integral_.setZero();
  disturbance_.setZero();
  last_thrust_N_.reset();
  last_thrust_scale_ = 1.0;
  last_t_ns_.reset();
  last_roll_ = 0.0;
  last_pitch_ = 0.0;
}

double PositionController::hover_thrust_estimate_N() const {
  return options_.mass_kg * hover_acceleration();
}

double PositionController::hover_acceleration() const {
  return kGravity + integral_.z() - disturbance_.z();
}

double PositionController::thrust_scale_of_hover() const {
  if (!options_.scale_thrust_by_hover_estimate) return 1.0;
  // Bounded as the integral and observer clamps bound h (4 m/s^2 either way: 0.59-1.41); the
  // floor only guards a degenerate option set.
  const double h = hover_acceleration();
  return std::max(h, 0.25 * kGravity) / kGravity;
}

void PositionController::observe(const VehicleStateEstimate& est, double dt) {
  const auto& o = options_;
  if (!o.disturbance_observer || dt <= 0.0 || !last_thrust_N_ || !est.specific_force_body ||
      !est.specific_force_body->allFinite()) {
    return;
  }
  // Unmodelled acceleration: a_true = R f + g and a_nominal = R ((T / m) e_z - D(v_body)) + g,
  // so d = a_true - a_nominal = R (f - (T / m) e_z + D(v_body)). The previous step's thrust is
  // the one that acted over the interval the IMU reading covers; the attitude is the
  // estimate's (a tilt error of the estimate only rotates the small difference, not gravity).
  // With the ground velocity in the drag term, d is the force of the wind, D (v_air - v) ~ -D w.
  const Eigen::Vector3d v_body = est.R_world_body.inverse() * est.v_world;
  const auto drag_of = [&v_body](int i, double c1, double c2) {
    return (c1 + c2 * std::abs(v_body[i])) * v_body[i];
  };
  const Eigen::Vector3d drag(
      drag_of(0, o.observer_drag_xy_per_s, o.observer_quadratic_drag_xy_per_m),
      drag_of(1, o.observer_drag_xy_per_s, o.observer_quadratic_drag_xy_per_m),
      drag_of(2, o.observer_drag_z_per_s, o.observer_quadratic_drag_z_per_m));
  // With the thrust scale the nominal rotors give (T / m) / s, s = h / g the scale the previous
  // command used; the hover term (g - h) e_z keeps d_z the shortfall the scale is made of (at
  // hover f = g e_z, T / m = h: d_z = g - h as without the scale). A tilted vehicle then shows
  // no horizontal d_z sin(theta): the scale already gives the tilt its acceleration (counted
  // twice it raised the horizontal gain by 1 / (2 - h / g)). Left: an external vertical force
  // reads as a shortfall and is scaled with the thrust (a horizontal error d_z tan(theta)).
  const double s = last_thrust_scale_;
  const Eigen::Vector3d raw =
      est.R_world_body * (*est.specific_force_body -
                          Eigen::Vector3d(0.0, 0.0, *last_thrust_N_ / (o.mass_kg * s)) + drag) +
      Eigen::Vector3d(0.0, 0.0, kGravity * (1.0 - s));
  // First-order low-pass, exact discretisation of d' = (raw - d) / tau.
  const double a_xy = 1.0 - std::exp(-dt / o.observer_time_constant_xy_s);
  const double a_z = 1.0 - std::exp(-dt / o.observer_time_constant_z_s);
  disturbance_.head<2>() += a_xy * (raw.head<2>() - disturbance_.head<2>());
  disturbance_.z() += a_z * (raw.z() - disturbance_.z());
  limit_horizontal(disturbance_, o.observer_limit_xy_m_s2);
  disturbance_.z() =
      std::clamp(disturbance_.z(), -o.observer_limit_z_m_s2, o.observer_limit_z_m_s2);
}

PositionController::Thrust PositionController::thrust_for(const Eigen::Vector3d& a_cmd,
                                                          ControllerOutput& out) const {
  // Thrust vector with gravity feed-forward, F = m (a + g e_z), then tilt and thrust limits:
  // the vertical part has priority, the horizontal part is scaled into the tilt cone. With the
  // thrust scale, the learnt hover acceleration h = g + I_z - d_z is a shortfall of the rotors'
  // force: F = m (h / g) (a' + g e_z), a' the command without I_z - d_z, whose vertical part is
  // m (h + (h / g) a'_z), the same as before up to the feedback's scale.
  const auto& o = options_;
  const double thrust_scale = thrust_scale_of_hover();
  Eigen::Vector3d a_shaped = a_cmd;
  if (o.scale_thrust_by_hover_estimate) a_shaped.z() -= integral_.z() - disturbance_.z();
  Eigen::Vector3d F = o.mass_kg * thrust_scale * (a_shaped + Eigen::Vector3d(0.0, 0.0, kGravity));
  if (F.z() < o.min_thrust_N) {
    F.z() = o.min_thrust_N;
    out.thrust_limited = true;
  }
  out.tilt_limited = limit_horizontal(F, F.z() * std::tan(o.max_tilt_deg * kDegToRad));
  double thrust = F.norm();
  if (thrust > o.max_thrust_N) {
    // Keep the vertical part where possible; give up horizontal authority first.
    out.thrust_limited = true;
    const double z = std::min(F.z(), o.max_thrust_N);
    const double xy_max = std::sqrt(std::max(0.0, o.max_thrust_N * o.max_thrust_N - z * z));
    F.z() = z;
    out.tilt_limited |= limit_horizontal(F, xy_max);
    thrust = F.norm();
  } else if (thrust < o.min_thrust_N) {
    thrust = o.min_thrust_N;
    out.thrust_limited = true;
  }
  // What the vehicle is asked for on the learnt thrust scale (the nominal model's when off).
  out.acceleration_command_world =
      F / (o.mass_kg * thrust_scale) - Eigen::Vector3d(0.0, 0.0, kGravity);
  if (o.scale_thrust_by_hover_estimate) {
    out.acceleration_command_world.z() += integral_.z() - disturbance_.z();
  }
  return {F, thrust, thrust_scale};
}

void PositionController::integrate(const Eigen::Vector3d& e_v, const Thrust& thrust,
                                   bool accel_limited, const ControllerOutput& out, double dt) {
  // Anti-windup: integrate only while the output is not saturated in the error's direction
  // (conditional integration), and clamp. With the observer the clamp holds the sum of the
  // two disturbance terms, I - d, to the integral's limits, so that the integral cannot wind up
  // against the observer (e.g. while the observer still converges) beyond what the integral
  // alone could command.
  if (dt <= 0.0) return;
  const auto& o = options_;
  const Eigen::Vector3d& F = thrust.F;
  const double scale = o.disturbance_observer ? o.observer_integral_scale : 1.0;
  if (!(out.tilt_limited || accel_limited)) {
    integral_.head<2>() += scale * o.velocity_integral_gain_xy * e_v.head<2>() * dt;
    Eigen::Vector3d total = integral_ - disturbance_;
    limit_horizontal(total, o.integral_limit_xy_m_s2);
    integral_.head<2>() = total.head<2>() + disturbance_.head<2>();
    limit_horizontal(integral_, o.integral_limit_xy_m_s2);
  }
  const bool z_saturated_up = out.thrust_limited && F.z() >= o.max_thrust_N * 0.999;
  const bool z_saturated_down = out.thrust_limited && F.z() <= o.min_thrust_N * 1.001;
  if (!(z_saturated_up && e_v.z() > 0.0) && !(z_saturated_down && e_v.z() < 0.0)) {
    const double z = integral_.z() + scale * o.velocity_integral_gain_z * e_v.z() * dt;
    const double lo =
        std::max(-o.integral_limit_z_m_s2, disturbance_.z() - o.integral_limit_z_m_s2);
    const double hi = std::min(o.integral_limit_z_m_s2, disturbance_.z() + o.integral_limit_z_m_s2);
    integral_.z() = lo <= hi ? std::clamp(z, lo, hi) : 0.5 * (lo + hi);
  }
}

ControllerOutput PositionController::update(const VehicleStateEstimate& est,
                                            const PositionReference& ref) {
  const auto& o = options_;
  double dt = 0.0;
  if (last_t_ns_) dt = ns_to_s(est.t_ns - *last_t_ns_);
  if (!(dt > 0.0 && dt <= 0.5)) dt = 0.0;
  last_t_ns_ = est.t_ns;

  ControllerOutput out;
  observe(est, dt);
  out.disturbance_m_s2 = disturbance_;
  // Position P -> velocity command, with the reference's velocity as feed-forward.
  const Eigen::Vector3d e_p = ref.p_world - est.p_world;
  Eigen::Vector3d v_cmd =
      ref.v_world + Eigen::Vector3d(o.position_gain_xy * e_p.x(), o.position_gain_xy * e_p.y(),
                                    o.position_gain_z * e_p.z());
  out.speed_limited = limit_horizontal(v_cmd, o.max_speed_xy_m_s);
  if (std::abs(v_cmd.z()) > o.max_speed_z_m_s) {
    v_cmd.z() = std::copysign(o.max_speed_z_m_s, v_cmd.z());
    out.speed_limited = true;
  }
  out.velocity_command_world = v_cmd;

  // Velocity PI -> acceleration command, with the reference's acceleration as feed-forward.
  const Eigen::Vector3d e_v = v_cmd - est.v_world;
  // The observer's estimate is subtracted: the command asks for the acceleration the nominal
  // model must produce so that the vehicle gets ref + PI despite d.
  Eigen::Vector3d a_cmd =
      ref.a_world + integral_ - disturbance_ +
      Eigen::Vector3d(o.velocity_gain_xy * e_v.x(), o.velocity_gain_xy * e_v.y(),
                      o.velocity_gain_z * e_v.z());
  const bool accel_limited = limit_horizontal(a_cmd, o.max_accel_xy_m_s2);

  const Thrust thrust = thrust_for(a_cmd, out);
  const Eigen::Vector3d& F = thrust.F;
  integrate(e_v, thrust, accel_limited, out, dt);
  out.integral_m_s2 = integral_;

  // Thrust direction in the heading frame -> ZYX roll and pitch: b = Ry(pitch) Rx(roll) e_z
  // = (cos r sin p, -sin r, cos r cos p).
  const double yaw = yaw_of(est.R_world_body);
  const Eigen::Vector3d b = SO3::exp(Eigen::Vector3d(0.0, 0.0, -yaw)) * F.normalized();
  double roll = std::asin(std::clamp(-b.y(), -1.0, 1.0));
  double pitch = std::atan2(b.x(), b.z());
  if (dt > 0.0) {
    const double max_step = o.max_tilt_rate_deg_s * kDegToRad * dt;
    roll = std::clamp(roll, last_roll_ - max_step, last_roll_ + max_step);
    pitch = std::clamp(pitch, last_pitch_ - max_step, last_pitch_ + max_step);
  }
  last_roll_ = roll;
  last_pitch_ = pitch;

  const double max_yaw_rate = o.max_yaw_rate_deg_s * kDegToRad;
  const double yaw_rate = ref.yaw_rate_rad_s + o.yaw_gain * wrap_angle(ref.yaw_rad - yaw);

  out.command.roll_rad = roll;
  out.command.pitch_rad = pitch;
  out.command.yaw_rate_rad_s = std::clamp(yaw_rate, -max_yaw_rate, max_yaw_rate);
  out.command.thrust_N = thrust.magnitude_N;
  last_thrust_N_ = thrust.magnitude_N;
  last_thrust_scale_ = thrust.scale;
  return out;
}

}  // namespace kestrel::control
