// The position controller's acceleration disturbance observer (PositionControllerOptions::
// disturbance_observer) on the quadrotor model without vision (closed_loop.hpp): its estimate
// converges to a known external force and to a thrust deficit, it halves the drift a step of
// wind causes with the velocity integral alone, and a noisy IMU does not shake the tilt command.
#include <gtest/gtest.h>

#include <cmath>

#include "closed_loop.hpp"
#include "kestrel/core/units.hpp"

namespace kestrel::test {
namespace {

control::PositionControllerOptions with_observer(bool on) {
  control::PositionControllerOptions o;
  o.disturbance_observer = on;
  return o;
}

const Eigen::Vector3d kHover(0.0, 0.0, 1.5);

TEST(DisturbanceObserver, ConvergesToAConstantExternalForce) {
  // A vertical external force is a shortfall of the thrust to the thrust scale (below); this
  // test checks the world-frame estimate of a force, so without it.
  control::PositionControllerOptions o = with_observer(true);
  o.scale_thrust_by_hover_estimate = false;
  ClosedLoop loop(hover_at(kHover), o);
  loop.reference = [](double) { return point(kHover); };
  loop.run(3.0);
  EXPECT_LT(loop.controller.disturbance_estimate_m_s2().norm(), 0.05) << "no disturbance yet";
  // 1.5 N sideways and 1 N down on the 1.2 kg vehicle: d = (1.25, 0, -0.83) m/s^2.
  const Eigen::Vector3d force(1.5, 0.0, -1.0);
  const Eigen::Vector3d d = force / loop.vehicle_parameters.mass_kg;
  loop.vehicle.quadrotor().set_external_force_world(force);
  // Five time constants (0.3 s): within 10 % of the force. The drag of the small drift the
  // step causes adds to the estimate while the vehicle moves.
  loop.run(1.5);
  const Eigen::Vector3d early = loop.controller.disturbance_estimate_m_s2();
  EXPECT_LT((early - d).norm(), 0.1 * d.norm()) << early.transpose();
  loop.run(3.5);
  const Eigen::Vector3d late = loop.controller.disturbance_estimate_m_s2();
  EXPECT_LT((late - d).norm(), 0.03 * d.norm()) << late.transpose();
  // The integral holds only a residual of what the observer explains.
  EXPECT_LT(
      loop.controller.update(ClosedLoop::perfect_estimate(loop.vehicle.state()), point(kHover))
          .integral_m_s2.norm(),
      0.15);
}

// The realistic world's mismatch (docs/flight.md, "World"): mass +15 %, thrust constant -10 %,
// unknown to the controllers; the vehicle starts in the air at the nominal hover rotor speed.
struct DeficitFlight {
  double estimate_at_1s_m_s2 = 0.0;  // d_z after 1 s
  double estimate_at_3s_m_s2 = 0.0;
  double max_drop_m = 0.0;  // largest height error
};

DeficitFlight thrust_deficit(bool observer) {
  sim::QuadrotorParameters heavy;
  heavy.mass_kg *= 1.15;
  heavy.thrust_coefficient *= 0.9;
  ClosedLoop loop(hover_at(kHover), with_observer(observer), {}, heavy);
  loop.reference = [](double) { return point(kHover); };
  DeficitFlight r;
  for (const LoopSample& s : loop.run(1.0)) {
    r.max_drop_m = std::max(r.max_drop_m, std::abs(s.p_true.z() - kHover.z()));
  }
  r.estimate_at_1s_m_s2 = loop.controller.disturbance_estimate_m_s2().z();
  for (const LoopSample& s : loop.run(2.0)) {
    r.max_drop_m = std::max(r.max_drop_m, std::abs(s.p_true.z() - kHover.z()));
  }
  r.estimate_at_3s_m_s2 = loop.controller.disturbance_estimate_m_s2().z();
  for (const LoopSample& s : loop.run(3.0)) {
    r.max_drop_m = std::max(r.max_drop_m, std::abs(s.p_true.z() - kHover.z()));
  }
  return r;
}

TEST(DisturbanceObserver, ConvergesToAThrustDeficit) {
  // In hover the true thrust is 0.9 T, so 0.9 T / (1.15 m) = g: T / m = 12.53 m/s^2 and the
  // nominal model over-predicts the acceleration by d = (0.9 / 1.15 - 1) T / m = -2.73 m/s^2.
  const double d = (0.9 / 1.15 - 1.0) * control::kGravity * 1.15 / 0.9;
  const DeficitFlight on = thrust_deficit(true);
  EXPECT_NEAR(on.estimate_at_1s_m_s2, d, 0.15 * std::abs(d));
  EXPECT_NEAR(on.estimate_at_3s_m_s2, d, 0.03 * std::abs(d));
  const DeficitFlight off = thrust_deficit(false);
  EXPECT_EQ(off.estimate_at_3s_m_s2, 0.0) << "switched off, the observer must not estimate";
  std::printf("thrust deficit: largest height error %.1f cm with the observer, %.1f cm without\n",
              100.0 * on.max_drop_m, 100.0 * off.max_drop_m);
  EXPECT_LT(on.max_drop_m, 0.6 * off.max_drop_m);
}

TEST(DisturbanceObserver, WithTheThrustScaleSeparatesAShortfallFromASidewaysForce) {
  // The realistic world's heavy, weak vehicle in a sideways force, observer and thrust scale on:
  // d_z is the shortfall (as above) and d_xy the force alone, F / m_true; rotating the whole
  // thrust residual into the world, as without the scale, would add d_z sin(theta) = 0.28 of
  // the force to d_x at the tilt that holds it (theta = atan(F / (m_true g))).
  sim::QuadrotorParameters heavy;
  heavy.mass_kg *= 1.15;
  heavy.thrust_coefficient *= 0.9;
  ClosedLoop loop(hover_at(kHover), with_observer(true), {}, heavy);
  loop.reference = [](double) { return point(kHover); };
  loop.run(4.0);
  const Eigen::Vector3d force(2.0, 0.0, 0.0);
  loop.vehicle.quadrotor().set_external_force_world(force);
  loop.run(6.0);
  const Eigen::Vector3d d = loop.controller.disturbance_estimate_m_s2();
  const double shortfall = (0.9 / 1.15 - 1.0) * control::kGravity * 1.15 / 0.9;
  EXPECT_NEAR(d.x(), force.x() / heavy.mass_kg, 0.03 * force.x() / heavy.mass_kg) << d.transpose();
  EXPECT_NEAR(d.y(), 0.0, 0.01);
  EXPECT_NEAR(d.z(), shortfall, 0.03 * std::abs(shortfall));
  EXPECT_LT((loop.vehicle.state().p_world - kHover).norm(), 0.02);
}

struct StepResponse {
  double peak_m = 0.0;
  double settle_s = 0.0;  // time after the step until the error stays below 3 cm
};

StepResponse wind_step(bool observer) {
  ClosedLoop loop(hover_at(kHover), with_observer(observer));
  loop.reference = [](double) { return point(kHover); };
  loop.run(5.0);
  loop.vehicle.quadrotor().set_external_force_world(Eigen::Vector3d(1.5, 0.0, -1.0));
  StepResponse r;
  for (const LoopSample& s : loop.run(8.0)) {
    const double e = (s.p_true - s.p_ref).norm();
    r.peak_m = std::max(r.peak_m, e);
    if (e >= 0.03) r.settle_s = s.t_s - 5.0;
    EXPECT_FALSE(s.crashed);
  }
  return r;
}

TEST(DisturbanceObserver, RejectsAStepOfWindFasterThanTheIntegralAlone) {
  const StepResponse on = wind_step(true);
  const StepResponse off = wind_step(false);
  std::printf(
      "wind step: peak %.1f cm, within 3 cm after %.2f s with the observer; "
      "%.1f cm, %.2f s with the integral alone\n",
      100.0 * on.peak_m, on.settle_s, 100.0 * off.peak_m, off.settle_s);
  EXPECT_LT(on.peak_m, 0.7 * off.peak_m);
  // Settling: with k_p 1.0, k_i 5 (the gains since 2026-12-05) the integral alone is back
  // within 3 cm after 1.9 s, the observer with it after 2.3 s (old gains: 3.9 s and 2.8 s).
  EXPECT_LT(on.settle_s, 3.0);
  EXPECT_LT(off.settle_s, 3.0);
}

// Tilt command noise in hover with the realistic world's IMU: 15x the MPU-6000 densities,
// read as the 5 ms mean the flight's IMU predictor gives the controller (one sample of the
// same density at 200 Hz).
double commanded_tilt_sigma_deg(bool observer) {
  io::ImuNoise noise = sim::default_vehicle_imu_noise();
  noise.accel_noise_density *= 15.0;
  noise.gyro_noise_density *= 15.0;
  noise.rate_hz = 200.0;
  ClosedLoop loop(hover_at(kHover), with_observer(observer));
  loop.imu.emplace(noise, 7, 0.0, 0.0);
  loop.reference = [](double) { return point(kHover); };
  loop.run(3.0);
  double sum = 0.0;
  double sum2 = 0.0;
  int n = 0;
  for (const LoopSample& s : loop.run(10.0)) {
    for (const double a : {s.command.roll_rad, s.command.pitch_rad}) {
      sum += a;
      sum2 += a * a;
      ++n;
    }
  }
  const double mean = sum / n;
  return std::sqrt(std::max(0.0, sum2 / n - mean * mean)) / kDegToRad;
}

TEST(DisturbanceObserver, NoisyImuDoesNotShakeTheTiltCommand) {
  const double on = commanded_tilt_sigma_deg(true);
  const double off = commanded_tilt_sigma_deg(false);
  std::printf("commanded tilt sigma with the 15x IMU: %.3f deg (observer), %.3f deg (off)\n", on,
              off);
  // 0.52 deg measured (tau_xy 0.4 s); the realistic flight's tilt command already moves by
  // 0.30 deg with the observer off (estimator noise, docs/flight.md).
  EXPECT_LT(on, 0.6);
}

}  // namespace
}  // namespace kestrel::test
