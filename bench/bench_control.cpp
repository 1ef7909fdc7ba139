// One position-controller step (200 Hz in the loop), one flight-controller-model + dynamics
// step (1 kHz), one PWM mapping: their cost bounds how much faster than real time the closed
// loop can run.
#include <benchmark/benchmark.h>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/sim/simulated_vehicle.hpp"

namespace {

using namespace kestrel;

void BM_PositionControllerUpdate(benchmark::State& state) {
  control::PositionController c;
  control::VehicleStateEstimate e;
  e.p_world = {0.1, -0.2, 1.4};
  e.v_world = {0.3, 0.1, 0.0};
  control::PositionReference r;
  r.p_world = {1.0, 0.0, 1.5};
  for (auto _ : state) {
    e.t_ns += 5'000'000;
    benchmark::DoNotOptimize(c.update(e, r));
  }
}
BENCHMARK(BM_PositionControllerUpdate);

void BM_QuadrotorDynamicsStep(benchmark::State& state) {
  const sim::QuadrotorParameters p;
  sim::Quadrotor q(p, sim::Quadrotor::hover_state(p, {0, 0, 1000}));
  const Eigen::Vector4d cmd =
      Eigen::Vector4d::Constant(p.hover_rotor_speed_rad_s()) + Eigen::Vector4d(1, -1, 1, -1);
  for (auto _ : state) {
    q.step(0.001, cmd);
    benchmark::DoNotOptimize(q.state());
  }
}
BENCHMARK(BM_QuadrotorDynamicsStep);

void BM_VehicleStepWithFlightController(benchmark::State& state) {
  const sim::QuadrotorParameters p;
  sim::SimulatedVehicle v(p, {}, sim::Quadrotor::hover_state(p, {0, 0, 1000}));
  control::PwmChannels pwm;
  pwm.us = {1520, 1490, 1420, 1505};
  for (auto _ : state) {
    v.step(0.001, pwm);
    benchmark::DoNotOptimize(v.state());
  }
}
BENCHMARK(BM_VehicleStepWithFlightController);

void BM_PwmMap(benchmark::State& state) {
  const control::PwmMapper m;
  control::AttitudeThrustCommand c{0.05, -0.03, 0.1, 12.0};
  for (auto _ : state) {
    c.roll_rad += 1e-9;
    benchmark::DoNotOptimize(m.map(c));
  }
}
BENCHMARK(BM_PwmMap);

}  // namespace
