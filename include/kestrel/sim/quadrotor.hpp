// Rigid-body dynamics of an X-configuration quadrotor: four rotors with thrust and drag-torque
// coefficients and first-order motor lag, body drag, a flat ground with touchdown/crash
// detection. Defaults: a DJI Phantom-class vehicle (thesis table C.3: < 1200 g take-off
// weight, 350 mm diagonal, 45 deg max tilt, 10 m/s max speed). Deterministic, fixed-step RK4.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>
#include <string>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::sim {

/// Physical parameters. Rotor i sits at angle 45 + 90 i degrees in the body x-y plane
/// (front-left, rear-left, rear-right, front-right), at arm_length_m from the centre; rotors
/// 0 and 2 spin clockwise seen from above (their drag torque turns the body counter-clockwise,
/// +z), rotors 1 and 3 counter-clockwise.
struct QuadrotorParameters {
  double mass_kg = 1.2;         ///< table C.3: take-off weight < 1200 g
  double arm_length_m = 0.175;  ///< table C.3: 350 mm motor-to-motor diagonal / 2
  /// Principal moments (kg m^2) of a 1.2 kg frame with 0.175 m arms, motors at the tips.
  Eigen::Vector3d inertia_kg_m2{0.0120, 0.0120, 0.0220};
  /// Rotor thrust f = k_f w^2 (N per (rad/s)^2): 7 N per rotor at full speed, thrust/weight
  /// 2.4 (Phantom 1: 2212 motors, 8x4.5 propellers on 3S).
  double thrust_coefficient = 7.0e-6;
  /// Rotor drag torque m = k_m w^2 (N m per (rad/s)^2), k_m / k_f = 0.016 m (8" propellers).
  double drag_torque_coefficient = 1.12e-7;
  double motor_time_constant_s = 0.03;  ///< first-order lag of rotor speed to its command
  double max_rotor_speed_rad_s = 1000.0;
  double min_rotor_speed_rad_s = 0.0;
  /// Body drag F = -(c1 + c2 |v|) v per body axis (N per m/s, N per (m/s)^2): with the 45 deg
  /// tilt of table C.3 the vehicle tops out near its 10 m/s maximum speed.
  Eigen::Vector3d linear_drag_N_s_m{0.30, 0.30, 0.40};
  Eigen::Vector3d quadratic_drag_N_s2_m2{0.09, 0.09, 0.12};
  double angular_drag_N_m_s = 2.0e-3;  ///< rotational damping torque per rad/s
  /// Centre of mass relative to the rotors' geometric centre, body frame (m): the rotors'
  /// torque arms are taken about it (an asymmetric frame or payload; 0: symmetric).
  Eigen::Vector3d center_of_mass_offset_m = Eigen::Vector3d::Zero();
  double ground_z_m = 0.0;  ///< the floor plane
  /// A touchdown faster than this, or with more tilt, is a crash.
  /// The landing gear's compression: the contact itself is resolved in one step (the vehicle
  /// stops and settles level at once), but the IMU feels the touchdown's velocity change and
  /// levelling rotation spread over about this time, as through real legs (a 0.5 m/s touchdown:
  /// ~25 m/s^2 at its peak, inside an IMU's range; in one 1 ms step it would read 500).
  double touchdown_time_s = 0.02;
  double crash_speed_m_s = 2.0;
  double crash_tilt_deg = 60.0;
  double gravity_m_s2 = 9.81;
  double max_integration_step_s = 0.001;  ///< step() subdivides longer steps

  /// Total thrust of the four rotors at full speed.
  [[nodiscard]] double max_thrust_N() const {
    return 4.0 * thrust_coefficient * max_rotor_speed_rad_s * max_rotor_speed_rad_s;
  }
  [[nodiscard]] double hover_thrust_N() const { return mass_kg * gravity_m_s2; }
  /// Rotor speed at which the four rotors together carry the weight.
  [[nodiscard]] double hover_rotor_speed_rad_s() const;

  /// Throws InputError naming the first invalid field.
  void validate() const;
  [[nodiscard]] std::string to_yaml() const;
  static QuadrotorParameters from_yaml(const YAML::Node& node, const std::string& source);
  /// The parameters at the top level or under a `vehicle:` key.
  static QuadrotorParameters load(const std::filesystem::path& path);

  template <typename V>
  void visit_fields(V&& v) {
    v("mass_kg", mass_kg);
    v("arm_length_m", arm_length_m);
    v("inertia_kg_m2", inertia_kg_m2);
    v("thrust_coefficient", thrust_coefficient);
    v("drag_torque_coefficient", drag_torque_coefficient);
    v("motor_time_constant_s", motor_time_constant_s);
    v("max_rotor_speed_rad_s", max_rotor_speed_rad_s);
    v("min_rotor_speed_rad_s", min_rotor_speed_rad_s);
    v("linear_drag_N_s_m", linear_drag_N_s_m);
    v("quadratic_drag_N_s2_m2", quadratic_drag_N_s2_m2);
    v("angular_drag_N_m_s", angular_drag_N_m_s);
    v("center_of_mass_offset_m", center_of_mass_offset_m);
    v("ground_z_m", ground_z_m);
    v("touchdown_time_s", touchdown_time_s);
    v("crash_speed_m_s", crash_speed_m_s);
    v("crash_tilt_deg", crash_tilt_deg);
    v("gravity_m_s2", gravity_m_s2);
    v("max_integration_step_s", max_integration_step_s);
  }
};

/// The true state of the vehicle. a_world and alpha_body are the derivatives at t_ns (for the
/// IMU simulator); they are outputs, not integrated.
struct QuadrotorState {
  TimeNs t_ns = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  SO3 R_world_body;
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();
  Eigen::Vector4d rotor_speed_rad_s = Eigen::Vector4d::Zero();
  Eigen::Vector3d a_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d alpha_body = Eigen::Vector3d::Zero();
  /// What the landing gear adds to an IMU's readings after a touchdown (world-frame
  /// acceleration, body rate; zero otherwise): QuadrotorParameters::touchdown_time_s. Not part
  /// of the dynamics, which settled the contact at once.
  Eigen::Vector3d contact_accel_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d contact_rate_body = Eigen::Vector3d::Zero();
  bool on_ground = false;
  bool crashed = false;              ///< latched: a hard touchdown happened
  double touchdown_speed_m_s = 0.0;  ///< speed at the last touchdown
};

class Quadrotor {
 public:
  explicit Quadrotor(QuadrotorParameters parameters = {}, QuadrotorState initial = {});

  /// Advances by dt_s (split into steps of at most max_integration_step_s) holding the
  /// rotor speed commands (clamped to [min, max]); t_ns advances by round(dt_s * 1e9).
  void step(double dt_s, const Eigen::Vector4d& rotor_speed_command_rad_s);

  /// Hovering at p_world, level, rotors at hover speed.
  static QuadrotorState hover_state(const QuadrotorParameters& parameters,
                                    const Eigen::Vector3d& p_world, double yaw_rad = 0.0,
                                    TimeNs t_ns = 0);

  /// A constant external force (wind, a push) in the world frame, N.
  void set_external_force_world(const Eigen::Vector3d& f) { external_force_world_ = f; }
  /// The air's velocity in the world frame (m/s), held until the next call: the body drag
  /// acts on the air-relative velocity v - wind.
  void set_wind_world(const Eigen::Vector3d& wind) { wind_world_ = wind; }
  [[nodiscard]] const Eigen::Vector3d& wind_world() const { return wind_world_; }

  [[nodiscard]] const QuadrotorState& state() const { return state_; }
  void set_state(const QuadrotorState& s) { state_ = s; }
  [[nodiscard]] const QuadrotorParameters& parameters() const { return parameters_; }

  /// Body-frame thrust and torque (N, N m) of the rotors at the given speeds: the mixer
  /// matrix [T, tau_x, tau_y, tau_z] = M [w_0^2 .. w_3^2].
  [[nodiscard]] Eigen::Matrix4d allocation_matrix() const;

 private:
  void integrate(double h, const Eigen::Vector4d& command);
  void resolve_ground_contact();
  void release_touchdown(double h);

  QuadrotorParameters parameters_;
  QuadrotorState state_;
  Eigen::Vector3d external_force_world_ = Eigen::Vector3d::Zero();
  // A touchdown's velocity change and levelling rotation (world frame) not yet felt by the IMU.
  Eigen::Vector3d touchdown_dv_world_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d touchdown_rotation_world_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d wind_world_ = Eigen::Vector3d::Zero();
};

}  // namespace kestrel::sim
