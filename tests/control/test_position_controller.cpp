#include "kestrel/core/units.hpp"
// The position controller in closed loop on perfect state (true state as the estimate):
// hover, step responses (overshoot, settling), a 2 m square at 0.5 m/s, a disturbance, yaw,
// and the limits on their own.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "closed_loop.hpp"

namespace kestrel::control {
namespace {

using test::ClosedLoop;
using test::hover_at;
using test::point;

TEST(PositionControllerClosedLoop, HoverHoldsWithinACentimetre) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  loop.vehicle.quadrotor().set_external_force_world({0.3, -0.2, 0.0});  // a light draught
  loop.reference = [](double) { return point({0, 0, 1.5}); };
  const auto log = loop.run(20.0);
  const double rms = test::rms_error(log, 10.0);
  double max_err = 0.0;
  for (const auto& s : log)
    if (s.t_s >= 10.0) max_err = std::max(max_err, (s.p_true - s.p_ref).norm());
  std::printf("[figure] hover (0.3 N draught): rms %.4f m, max %.4f m after 10 s\n", rms, max_err);
  EXPECT_LT(max_err, 0.01);
  EXPECT_FALSE(log.back().crashed);
}

struct StepFigures {
  double overshoot_m = 0.0;
  double settling_s = 0.0;  // last time outside 5 % of the step
  double final_error_m = 0.0;
};

StepFigures step_response(const Eigen::Vector3d& step, double duration_s) {
  const Eigen::Vector3d start(0, 0, 1.5);
  ClosedLoop loop(hover_at(start));
  loop.reference = [&](double t) { return point(t < 0.5 ? start : Eigen::Vector3d(start + step)); };
  const auto log = loop.run(duration_s);
  StepFigures f;
  const Eigen::Vector3d dir = step.normalized();
  for (const auto& s : log) {
    if (s.t_s < 0.5) continue;
    const double along = (s.p_true - start).dot(dir);
    f.overshoot_m = std::max(f.overshoot_m, along - step.norm());
    if ((s.p_true - (start + step)).norm() > 0.05 * step.norm()) f.settling_s = s.t_s - 0.5;
  }
  f.final_error_m = (log.back().p_true - (start + step)).norm();
  return f;
}

TEST(PositionControllerClosedLoop, HorizontalStepSettlesWithoutWildOvershoot) {
  const StepFigures f = step_response({1.0, 0.0, 0.0}, 8.0);
  std::printf("[figure] 1 m x step: overshoot %.3f m, 5%% settling %.2f s, final %.4f m\n",
              f.overshoot_m, f.settling_s, f.final_error_m);
  EXPECT_LT(f.overshoot_m, 0.10);
  EXPECT_LT(f.settling_s, 4.0);
  EXPECT_LT(f.final_error_m, 0.01);
}

TEST(PositionControllerClosedLoop, VerticalStepSettlesWithoutWildOvershoot) {
  const StepFigures f = step_response({0.0, 0.0, 1.0}, 6.0);
  std::printf("[figure] 1 m z step: overshoot %.3f m, 5%% settling %.2f s, final %.4f m\n",
              f.overshoot_m, f.settling_s, f.final_error_m);
  EXPECT_LT(f.overshoot_m, 0.10);
  EXPECT_LT(f.settling_s, 3.0);
  EXPECT_LT(f.final_error_m, 0.01);
}

TEST(PositionControllerClosedLoop, LargeStepRespectsTheTiltAndSpeedLimits) {
  const Eigen::Vector3d start(0, 0, 1.5);
  ClosedLoop loop(hover_at(start));
  loop.reference = [&](double) { return point({10.0, -5.0, 1.5}); };
  const auto log = loop.run(12.0);
  double max_tilt = 0.0, max_speed = 0.0;
  for (std::size_t i = 0; i < log.size(); ++i) {
    max_tilt = std::max(max_tilt, std::hypot(log[i].command.roll_rad, log[i].command.pitch_rad));
    if (i > 0)
      max_speed = std::max(max_speed, (log[i].p_true - log[i - 1].p_true).head<2>().norm() * 200.0);
  }
  std::printf("[figure] 11 m step: max commanded tilt %.1f deg, max speed %.2f m/s, final %.3f m\n",
              max_tilt / kDegToRad, max_speed,
              (log.back().p_true - Eigen::Vector3d(10, -5, 1.5)).norm());
  EXPECT_LT(max_tilt, (30.0 + 0.5) * kDegToRad * std::sqrt(2.0));
  EXPECT_LT(max_speed, 2.0 * 1.15);
  EXPECT_LT((log.back().p_true - Eigen::Vector3d(10, -5, 1.5)).norm(), 0.05);
}

// A 2 m square at 0.5 m/s, corners with 0.5 s accelerations (trapezoidal speed along each side).
PositionReference square(double t, double side, double speed) {
  const double accel_time = 0.5;
  const double a = speed / accel_time;
  const double side_time = side / speed + accel_time;
  const Eigen::Vector3d corners[5] = {
      {0, 0, 1.5}, {side, 0, 1.5}, {side, side, 1.5}, {0, side, 1.5}, {0, 0, 1.5}};
  PositionReference r;
  if (t < 0.0 || t >= 4 * side_time) {
    r.p_world = corners[0];
    return r;
  }
  const int k = static_cast<int>(t / side_time);
  const double u = t - k * side_time;
  const Eigen::Vector3d dir = (corners[k + 1] - corners[k]).normalized();
  double s, v, acc;
  if (u < accel_time) {
    s = 0.5 * a * u * u;
    v = a * u;
    acc = a;
  } else if (u < side_time - accel_time) {
    s = 0.5 * a * accel_time * accel_time + speed * (u - accel_time);
    v = speed;
    acc = 0.0;
  } else {
    const double d = side_time - u;
    s = side - 0.5 * a * d * d;
    v = a * d;
    acc = -a;
  }
  r.p_world = corners[k] + s * dir;
  r.v_world = v * dir;
  r.a_world = acc * dir;
  return r;
}

TEST(PositionControllerClosedLoop, TracksA2MetreSquareAtHalfAMetrePerSecond) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  loop.reference = [](double t) { return square(t - 1.0, 2.0, 0.5); };
  const auto log = loop.run(20.0);
  double max_err = 0.0;
  for (const auto& s : log) max_err = std::max(max_err, (s.p_true - s.p_ref).norm());
  const double rms = test::rms_error(log, 0.0);
  std::printf("[figure] 2 m square at 0.5 m/s: rms %.4f m, max %.4f m\n", rms, max_err);
  EXPECT_LT(rms, 0.03);
  EXPECT_LT(max_err, 0.08);
}

TEST(PositionControllerClosedLoop, TurnsToTheReferenceHeading) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  loop.reference = [](double) { return point({0, 0, 1.5}, 2.5); };
  const auto log = loop.run(6.0);
  EXPECT_NEAR(wrap_angle(yaw_of(loop.vehicle.state().R_world_body) - 2.5), 0.0, 1.0 * kDegToRad);
  EXPECT_LT((log.back().p_true - Eigen::Vector3d(0, 0, 1.5)).norm(), 0.02);
}

TEST(PositionControllerClosedLoop, IntegratorLearnsAMassError) {
  // The controller believes 1.0 kg; the vehicle weighs 1.2 kg. The z integrator makes it up.
  PositionControllerOptions o;
  o.mass_kg = 1.0;
  ClosedLoop loop(hover_at({0, 0, 1.5}), o);
  loop.reference = [](double) { return point({0, 0, 1.5}); };
  const auto log = loop.run(12.0);
  EXPECT_LT(std::abs(log.back().p_true.z() - 1.5), 0.01);
  EXPECT_NEAR(loop.controller.hover_thrust_estimate_N(), 1.2 * kGravity, 0.1);
}

TEST(PositionController, AntiWindupStopsIntegratingIntoTheTiltLimit) {
  PositionController c;
  VehicleStateEstimate e;
  e.p_world = {0, 0, 1.5};
  const PositionReference r = point({50.0, 0.0, 1.5});
  // Stuck (e.g. held by a tether) far from the reference for 20 s: saturated throughout.
  ControllerOutput out;
  for (int i = 0; i < 4000; ++i) {
    e.t_ns = static_cast<TimeNs>(i) * 5'000'000;
    out = c.update(e, r);
  }
  EXPECT_TRUE(out.tilt_limited || out.speed_limited);
  // Integration stops once the acceleration limit is reached (velocity gain x the 2 m/s speed
  // limit is at or beyond the 5 m/s^2 acceleration limit), far below the 2 m/s^2 clamp.

  EXPECT_LT(out.integral_m_s2.head<2>().norm(), 0.65);
  EXPECT_LE(std::hypot(out.command.roll_rad, out.command.pitch_rad), 30.0 * kDegToRad * 1.001);
}

TEST(PositionController, FirstStepHoldsTheWeightAndTiltRateIsLimited) {
  PositionController c;
  VehicleStateEstimate e;
  e.p_world = {0, 0, 1.5};
  auto out = c.update(e, point({0, 0, 1.5}));
  EXPECT_NEAR(out.command.thrust_N, 1.2 * kGravity, 1e-9);
  EXPECT_NEAR(out.command.roll_rad, 0.0, 1e-12);
  e.t_ns = 5'000'000;
  out = c.update(e, point({0, 5.0, 1.5}));  // a sudden far reference
  EXPECT_LE(std::abs(out.command.roll_rad), 180.0 * kDegToRad * 0.005 + 1e-12);
}

}  // namespace
}  // namespace kestrel::control
