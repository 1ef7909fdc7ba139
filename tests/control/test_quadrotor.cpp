// Vehicle dynamics against analytic cases: hover thrust = m g, free fall, pure yaw torque,
// a pure roll torque, drag-limited top speed, ground contact.
#include <gtest/gtest.h>

#include <cmath>

#include "kestrel/sim/quadrotor.hpp"

namespace kestrel::sim {
namespace {

TEST(Quadrotor, HoverSpeedHoldsTheWeight) {
  const QuadrotorParameters p;
  const double w = p.hover_rotor_speed_rad_s();
  EXPECT_NEAR(4.0 * p.thrust_coefficient * w * w, p.mass_kg * p.gravity_m_s2, 1e-9);
  Quadrotor q(p, Quadrotor::hover_state(p, {0, 0, 2}));
  for (int i = 0; i < 5000; ++i) q.step(0.001, Eigen::Vector4d::Constant(w));
  EXPECT_NEAR((q.state().p_world - Eigen::Vector3d(0, 0, 2)).norm(), 0.0, 1e-9);
  EXPECT_LT(q.state().omega_body.norm(), 1e-12);
  EXPECT_EQ(q.state().t_ns, 5'000'000'000);
}

TEST(Quadrotor, FreeFallWithoutDragIsBallistic) {
  QuadrotorParameters p;
  p.linear_drag_N_s_m.setZero();
  p.quadratic_drag_N_s2_m2.setZero();
  QuadrotorState s;
  s.p_world = {0, 0, 10};
  s.v_world = {1.0, 0.0, 2.0};
  Quadrotor q(p, s);
  for (int i = 0; i < 1000; ++i) q.step(0.001, Eigen::Vector4d::Zero());
  const double t = 1.0;
  EXPECT_NEAR(q.state().p_world.x(), 1.0 * t, 1e-9);
  EXPECT_NEAR(q.state().p_world.z(), 10 + 2.0 * t - 0.5 * p.gravity_m_s2 * t * t, 1e-9);
  EXPECT_NEAR(q.state().v_world.z(), 2.0 - p.gravity_m_s2 * t, 1e-9);
  EXPECT_NEAR(q.state().a_world.z(), -p.gravity_m_s2, 1e-9);
}

TEST(Quadrotor, PureYawTorqueSpinsAboutZOnly) {
  QuadrotorParameters p;
  p.angular_drag_N_m_s = 0.0;
  p.motor_time_constant_s = 1e-3;  // rotor speeds settle almost at once
  p.max_integration_step_s = 1e-4;
  const double w0 = p.hover_rotor_speed_rad_s();
  const double dw = 50.0;
  // Rotors 0 and 2 faster, 1 and 3 slower: thrust sum ~ weight, no roll/pitch torque.
  const double a = std::sqrt(w0 * w0 + dw * dw), b = std::sqrt(w0 * w0 - dw * dw);
  const Eigen::Vector4d cmd(a, b, a, b);
  Quadrotor q(p, Quadrotor::hover_state(p, {0, 0, 5}));
  q.step(0.02, cmd);  // let the rotors settle
  const Eigen::Vector3d w_start = q.state().omega_body;
  const double T = 0.5;
  for (int i = 0; i < 500; ++i) q.step(0.001, cmd);
  const double tau_z = p.drag_torque_coefficient * 4.0 * dw * dw;
  const double expected = tau_z / p.inertia_kg_m2.z() * T;
  EXPECT_NEAR(q.state().omega_body.z() - w_start.z(), expected, 1e-6);
  EXPECT_LT(std::abs(q.state().omega_body.x()) + std::abs(q.state().omega_body.y()), 1e-9);
  EXPECT_NEAR(q.state().p_world.z(), 5.0, 1e-6);  // thrust unchanged: still hovering
  // Yaw angle = integral of the rate (constant acceleration from ~0).
  const Eigen::Vector3d x = q.state().R_world_body * Eigen::Vector3d::UnitX();
  const double alpha = tau_z / p.inertia_kg_m2.z();
  // Rotor lag (1 ms) delays the torque by about one time constant.
  EXPECT_NEAR(std::atan2(x.y(), x.x()), 0.5 * alpha * (T + 0.019) * (T + 0.019), 1e-4);
}

TEST(Quadrotor, RollTorqueFromTheLeftRotorsRollsRight) {
  QuadrotorParameters p;
  p.angular_drag_N_m_s = 0.0;
  const Quadrotor q0(p);
  const Eigen::Matrix4d M = q0.allocation_matrix();
  // Left rotors (0: front-left, 1: rear-left) push +roll (right side down) about +x.
  EXPECT_GT(M(1, 0), 0.0);
  EXPECT_GT(M(1, 1), 0.0);
  EXPECT_LT(M(1, 2), 0.0);
  // Front rotors (0, 3) push the nose up: -pitch about +y.
  EXPECT_LT(M(2, 0), 0.0);
  EXPECT_LT(M(2, 3), 0.0);
  EXPECT_GT(std::abs(M.determinant()), 0.0);
}

TEST(Quadrotor, DragLimitsTheSpeedNearTheRatedMaximum) {
  // 45 deg tilt with the vertical thrust holding the weight: table C.3's 10 m/s top speed.
  const QuadrotorParameters p;
  const double c1 = p.linear_drag_N_s_m.x(), c2 = p.quadratic_drag_N_s2_m2.x();
  const double force = p.mass_kg * p.gravity_m_s2;  // tan 45 = 1
  const double v = (-c1 + std::sqrt(c1 * c1 + 4 * c2 * force)) / (2 * c2);
  EXPECT_GT(v, 8.0);
  EXPECT_LT(v, 12.0);
}

TEST(Quadrotor, RestsOnTheGroundAndDetectsACrash) {
  QuadrotorParameters p;
  QuadrotorState s;
  s.p_world = {0, 0, 0};
  Quadrotor q(p, s);
  EXPECT_TRUE(q.state().on_ground);
  for (int i = 0; i < 100; ++i) q.step(0.001, Eigen::Vector4d::Constant(300.0));
  EXPECT_TRUE(q.state().on_ground);
  EXPECT_EQ(q.state().p_world.z(), 0.0);
  // Full power lifts off.
  for (int i = 0; i < 300; ++i) q.step(0.001, Eigen::Vector4d::Constant(p.max_rotor_speed_rad_s));
  EXPECT_FALSE(q.state().on_ground);
  EXPECT_GT(q.state().p_world.z(), 0.05);

  // Dropped from 3 m with the motors off: a crash.
  QuadrotorState high;
  high.p_world = {0, 0, 3};
  Quadrotor drop(p, high);
  for (int i = 0; i < 2000 && !drop.state().on_ground; ++i)
    drop.step(0.001, Eigen::Vector4d::Zero());
  EXPECT_TRUE(drop.state().on_ground);
  EXPECT_TRUE(drop.state().crashed);
  EXPECT_GT(drop.state().touchdown_speed_m_s, 5.0);
}

TEST(Quadrotor, MotorLagIsFirstOrder) {
  QuadrotorParameters p;
  Quadrotor q(p, Quadrotor::hover_state(p, {0, 0, 10}));
  const double w0 = q.state().rotor_speed_rad_s[0];
  const double target = w0 + 100.0;
  for (int i = 0; i < 30; ++i) q.step(0.001, Eigen::Vector4d::Constant(target));  // one tau
  EXPECT_NEAR((q.state().rotor_speed_rad_s[0] - w0) / 100.0, 1.0 - std::exp(-1.0), 1e-6);
}

// A touchdown settles the vehicle in one step, but what an IMU would feel is spread over the
// landing gear's touchdown_time_s: the world-frame accelerations it reports add up to the
// velocity the touchdown removed, the body rates to the levelling rotation, and the peak stays
// inside a 16 g accelerometer's range.
TEST(Quadrotor, TheImuFeelsATouchdownThroughTheLegs) {
  QuadrotorParameters p;
  QuadrotorState s;
  s.p_world = {0, 0, 0.0005};
  s.v_world = {0.2, -0.1, -0.5};
  s.R_world_body = SO3::exp(Eigen::Vector3d(0.06, -0.04, 0.3));  // ~4 deg of tilt, yaw 0.3
  Quadrotor q(p, s);
  Eigen::Vector3d felt_dv = Eigen::Vector3d::Zero();
  Eigen::Vector3d felt_rotation = Eigen::Vector3d::Zero();
  double peak = 0.0;
  bool touched = false;
  const double h = 0.001;
  for (int i = 0; i < 300; ++i) {  // 15 time constants
    q.step(h, Eigen::Vector4d::Zero());
    const QuadrotorState& now = q.state();
    touched = touched || now.on_ground;
    // Before the touchdown: free fall (a_world = -g); after it: at rest (a_world = 0).
    felt_dv += (now.a_world + now.contact_accel_world) * h;
    felt_rotation += now.R_world_body * now.contact_rate_body * h;
    peak = std::max(peak, now.contact_accel_world.norm());
  }
  ASSERT_TRUE(touched);
  EXPECT_FALSE(q.state().crashed);
  // Velocity: from s.v_world (plus the first step's fall) to rest.
  const Eigen::Vector3d removed = -s.v_world + Eigen::Vector3d(0, 0, p.gravity_m_s2 * h);
  EXPECT_LT((felt_dv - (-s.v_world)).norm(), 0.01 * removed.norm() + p.gravity_m_s2 * h);
  // Rotation: the tilt only (the heading is kept).
  const Eigen::Vector3d levelling = (q.state().R_world_body * s.R_world_body.inverse()).log();
  EXPECT_LT((felt_rotation - levelling).norm(), 0.01 * levelling.norm() + 1e-4);
  EXPECT_GT(levelling.norm(), 0.06);
  EXPECT_LT(peak, 16.0 * 9.81);
  EXPECT_GT(peak, 0.5 * removed.norm() / p.touchdown_time_s);  // felt, not lost
  // All of it released: nothing left after the gear has settled.
  EXPECT_EQ(q.state().contact_accel_world.norm(), 0.0);
}

}  // namespace
}  // namespace kestrel::sim
