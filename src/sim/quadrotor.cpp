// Quadrotor rigid-body dynamics (Newton-Euler in the body frame), RK4 with a renormalised
// quaternion, rotor lag, drag, ground contact.
#include "kestrel/sim/quadrotor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sim {

namespace {

// The integrated part of the state.
struct Rigid {
  Eigen::Vector3d p;
  Eigen::Vector3d v;
  Eigen::Quaterniond q;
  Eigen::Vector3d w;
  Eigen::Vector4d rotors;
};

struct Derivative {
  Eigen::Vector3d p_dot;
  Eigen::Vector3d v_dot;
  Eigen::Vector4d q_dot;  // coefficients (x, y, z, w)
  Eigen::Vector3d w_dot;
  Eigen::Vector4d rotors_dot;
};

Rigid advance(const Rigid& x, const Derivative& d, double h) {
  Rigid y;
  y.p = x.p + h * d.p_dot;
  y.v = x.v + h * d.v_dot;
  y.q.coeffs() = x.q.coeffs() + h * d.q_dot;
  y.q.normalize();
  y.w = x.w + h * d.w_dot;
  y.rotors = x.rotors + h * d.rotors_dot;
  return y;
}

double tilt_rad(const Eigen::Quaterniond& q) {
  return std::acos(std::clamp((q * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
}

}  // namespace

double QuadrotorParameters::hover_rotor_speed_rad_s() const {
  return std::sqrt(hover_thrust_N() / (4.0 * thrust_coefficient));
}

void QuadrotorParameters::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw InputError("vehicle parameter '" + field + "': " + why);
  };
  auto pos = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0)) fail(name, "must be positive and finite");
  };
  auto nonneg = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v >= 0.0)) fail(name, "must be >= 0 and finite");
  };
  pos("mass_kg", mass_kg);
  pos("arm_length_m", arm_length_m);
  for (int i = 0; i < 3; ++i) pos("inertia_kg_m2", inertia_kg_m2[i]);
  pos("thrust_coefficient", thrust_coefficient);
  nonneg("drag_torque_coefficient", drag_torque_coefficient);
  pos("motor_time_constant_s", motor_time_constant_s);
  pos("max_rotor_speed_rad_s", max_rotor_speed_rad_s);
  nonneg("min_rotor_speed_rad_s", min_rotor_speed_rad_s);
  if (min_rotor_speed_rad_s >= max_rotor_speed_rad_s) {
    fail("min_rotor_speed_rad_s", "must be below max_rotor_speed_rad_s");
  }
  for (int i = 0; i < 3; ++i) {
    nonneg("linear_drag_N_s_m", linear_drag_N_s_m[i]);
    nonneg("quadratic_drag_N_s2_m2", quadratic_drag_N_s2_m2[i]);
  }
  nonneg("angular_drag_N_m_s", angular_drag_N_m_s);
  if (!(std::isfinite(touchdown_time_s) && touchdown_time_s > 0.0 && touchdown_time_s <= 1.0)) {
    fail("touchdown_time_s", "must be in (0, 1] s");
  }
  for (int i = 0; i < 3; ++i) {
    if (!(std::isfinite(center_of_mass_offset_m[i]) &&
          std::abs(center_of_mass_offset_m[i]) < 0.5 * arm_length_m)) {
      fail("center_of_mass_offset_m", "must be finite and within half the arm length");
    }
  }
  if (!std::isfinite(ground_z_m)) fail("ground_z_m", "must be finite");
  pos("crash_speed_m_s", crash_speed_m_s);
  pos("crash_tilt_deg", crash_tilt_deg);
  pos("gravity_m_s2", gravity_m_s2);
  pos("max_integration_step_s", max_integration_step_s);
  // RK4 is stable for |lambda h| < 2.78; the rotor lag is the stiffest mode.
  if (max_integration_step_s > motor_time_constant_s) {
    fail("max_integration_step_s", "must not exceed motor_time_constant_s (RK4 stability)");
  }
  if (max_thrust_N() <= hover_thrust_N())
    fail("max_rotor_speed_rad_s", "the vehicle cannot lift its weight");
}

std::string QuadrotorParameters::to_yaml() const { return io::option_fields::to_yaml(*this); }

QuadrotorParameters QuadrotorParameters::from_yaml(const YAML::Node& node,
                                                   const std::string& source) {
  QuadrotorParameters p;
  io::option_fields::read_fields(node, source, "vehicle", p);
  p.validate();
  return p;
}

QuadrotorParameters QuadrotorParameters::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["vehicle"]) return from_yaml(root["vehicle"], path.string());
  return from_yaml(root, path.string());
}

Quadrotor::Quadrotor(QuadrotorParameters parameters, QuadrotorState initial)
    : parameters_(std::move(parameters)), state_(std::move(initial)) {
  parameters_.validate();
  state_.on_ground = state_.p_world.z() <= parameters_.ground_z_m;
  if (state_.on_ground) state_.p_world.z() = parameters_.ground_z_m;
}

QuadrotorState Quadrotor::hover_state(const QuadrotorParameters& parameters,
                                      const Eigen::Vector3d& p_world, double yaw_rad, TimeNs t_ns) {
  QuadrotorState s;
  s.t_ns = t_ns;
  s.p_world = p_world;
  s.R_world_body = SO3::exp(Eigen::Vector3d(0.0, 0.0, yaw_rad));
  s.rotor_speed_rad_s.setConstant(parameters.hover_rotor_speed_rad_s());
  return s;
}

Eigen::Matrix4d Quadrotor::allocation_matrix() const {
  const auto& P = parameters_;
  Eigen::Matrix4d M;
  const std::array<double, 4> spin{1.0, -1.0, 1.0, -1.0};  // +1: reaction torque along +z
  for (int i = 0; i < 4; ++i) {
    const double angle = std::numbers::pi / 4.0 + std::numbers::pi / 2.0 * i;
    // Torque arms about the centre of mass.
    const double x = P.arm_length_m * std::cos(angle) - P.center_of_mass_offset_m.x();
    const double y = P.arm_length_m * std::sin(angle) - P.center_of_mass_offset_m.y();
    M(0, i) = P.thrust_coefficient;
    M(1, i) = y * P.thrust_coefficient;  // tau = r x (0, 0, f)
    M(2, i) = -x * P.thrust_coefficient;
    M(3, i) = spin[static_cast<std::size_t>(i)] * P.drag_torque_coefficient;
  }
  return M;
}

void Quadrotor::step(double dt_s, const Eigen::Vector4d& rotor_speed_command_rad_s) {
  if (!(dt_s > 0.0) || !std::isfinite(dt_s)) return;
  const auto& P = parameters_;
  Eigen::Vector4d command = rotor_speed_command_rad_s;
  for (int i = 0; i < 4; ++i) {
    command[i] = std::isfinite(command[i])
                     ? std::clamp(command[i], P.min_rotor_speed_rad_s, P.max_rotor_speed_rad_s)
                     : P.min_rotor_speed_rad_s;
  }
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / P.max_integration_step_s - 1e-9)));
  const double h = dt_s / n;
  for (int k = 0; k < n; ++k) integrate(h, command);
  state_.t_ns += s_to_ns(dt_s);
}

void Quadrotor::integrate(double h, const Eigen::Vector4d& command) {
  const auto& P = parameters_;
  const Eigen::Matrix4d M = allocation_matrix();
  const Eigen::Vector3d J = P.inertia_kg_m2;
  const Eigen::Vector3d g(0.0, 0.0, -P.gravity_m_s2);

  auto derivative = [&](const Rigid& x) {
    Derivative d;
    d.rotors_dot = (command - x.rotors) / P.motor_time_constant_s;
    const Eigen::Vector4d wrench = M * x.rotors.cwiseAbs2();  // [T, tau_x, tau_y, tau_z]
    const Eigen::Matrix3d R = x.q.toRotationMatrix();
    const Eigen::Vector3d v_body = R.transpose() * (x.v - wind_world_);  // air-relative
    const Eigen::Vector3d drag_body =
        -(P.linear_drag_N_s_m + P.quadratic_drag_N_s2_m2.cwiseProduct(v_body.cwiseAbs()))
             .cwiseProduct(v_body);
    const Eigen::Vector3d force_body = Eigen::Vector3d(0.0, 0.0, wrench[0]) + drag_body;
    d.p_dot = x.v;
    d.v_dot = (R * force_body + external_force_world_) / P.mass_kg + g;
    const Eigen::Vector3d torque = wrench.tail<3>() - P.angular_drag_N_m_s * x.w;
    const Eigen::Vector3d Jw = J.cwiseProduct(x.w);
    d.w_dot = (torque - x.w.cross(Jw)).cwiseQuotient(J);  // Euler's equations
    // q_dot = 1/2 q (x) (0, w), body-frame rate.
    const Eigen::Quaterniond omega(0.0, x.w.x(), x.w.y(), x.w.z());
    d.q_dot = 0.5 * (x.q * omega).coeffs();
    return d;
  };

  Rigid x{state_.p_world, state_.v_world, state_.R_world_body.unit_quaternion(), state_.omega_body,
          state_.rotor_speed_rad_s};

  if (state_.on_ground) {
    // Resting on the floor: only the rotors move until the thrust lifts the weight.
    const Derivative d = derivative(x);
    if (d.v_dot.z() <= 0.0) {
      x.rotors += h * d.rotors_dot;
      state_.rotor_speed_rad_s = x.rotors;
      state_.a_world.setZero();
      state_.alpha_body.setZero();
      release_touchdown(h);
      return;
    }
    state_.on_ground = false;
  }

  const Derivative k1 = derivative(x);
  const Derivative k2 = derivative(advance(x, k1, h / 2));
  const Derivative k3 = derivative(advance(x, k2, h / 2));
  const Derivative k4 = derivative(advance(x, k3, h));
  Derivative sum;
  sum.p_dot = (k1.p_dot + 2 * k2.p_dot + 2 * k3.p_dot + k4.p_dot) / 6.0;
  sum.v_dot = (k1.v_dot + 2 * k2.v_dot + 2 * k3.v_dot + k4.v_dot) / 6.0;
  sum.q_dot = (k1.q_dot + 2 * k2.q_dot + 2 * k3.q_dot + k4.q_dot) / 6.0;
  sum.w_dot = (k1.w_dot + 2 * k2.w_dot + 2 * k3.w_dot + k4.w_dot) / 6.0;
  sum.rotors_dot = (k1.rotors_dot + 2 * k2.rotors_dot + 2 * k3.rotors_dot + k4.rotors_dot) / 6.0;
  x = advance(x, sum, h);

  const Derivative end = derivative(x);
  state_.p_world = x.p;
  state_.v_world = x.v;
  state_.R_world_body = SO3(x.q);
  state_.omega_body = x.w;
  state_.rotor_speed_rad_s = x.rotors;
  state_.a_world = end.v_dot;
  state_.alpha_body = end.w_dot;
  resolve_ground_contact();
  release_touchdown(h);
}

void Quadrotor::release_touchdown(double h) {
  state_.contact_accel_world.setZero();
  state_.contact_rate_body.setZero();
  if (touchdown_dv_world_.isZero() && touchdown_rotation_world_.isZero()) return;
  // First order through the legs: the share 1 - e^(-h/T) of what is left reaches the IMU in
  // this step, as a mean acceleration and a mean rate over it.
  const double share = 1.0 - std::exp(-h / parameters_.touchdown_time_s);
  const Eigen::Vector3d dv = share * touchdown_dv_world_;
  const Eigen::Vector3d dr = share * touchdown_rotation_world_;
  touchdown_dv_world_ -= dv;
  touchdown_rotation_world_ -= dr;
  state_.contact_accel_world = dv / h;
  state_.contact_rate_body = state_.R_world_body.inverse() * (dr / h);
  // Done once below what an IMU resolves (1e-6 m/s, 1e-6 rad).
  if (touchdown_dv_world_.norm() < 1e-6 && touchdown_rotation_world_.norm() < 1e-6) {
    touchdown_dv_world_.setZero();
    touchdown_rotation_world_.setZero();
  }
}

void Quadrotor::resolve_ground_contact() {
  const auto& P = parameters_;
  if (state_.p_world.z() > P.ground_z_m) return;
  const double speed = state_.v_world.norm();
  const double tilt_deg =
      tilt_rad(state_.R_world_body.unit_quaternion()) * 180.0 / std::numbers::pi;
  state_.touchdown_speed_m_s = speed;
  if (speed > P.crash_speed_m_s || tilt_deg > P.crash_tilt_deg) state_.crashed = true;
  // Settle on the floor, level, keeping the heading.
  const Eigen::Vector3d x_axis = state_.R_world_body * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(x_axis.y(), x_axis.x());
  const SO3 R_level = SO3::exp(Eigen::Vector3d(0.0, 0.0, yaw));
  // What the settling changed, for the IMU to feel through the legs (release_touchdown): the
  // velocity lost and the levelling rotation (world frame). The body rate it also stops is
  // part of the rotation it would have made, so it is not added again.
  touchdown_dv_world_ -= state_.v_world;
  touchdown_rotation_world_ += (R_level * state_.R_world_body.inverse()).log();
  state_.p_world.z() = P.ground_z_m;
  state_.v_world.setZero();
  state_.omega_body.setZero();
  state_.R_world_body = R_level;
  state_.a_world.setZero();
  state_.alpha_body.setZero();
  state_.on_ground = true;
}

}  // namespace kestrel::sim
