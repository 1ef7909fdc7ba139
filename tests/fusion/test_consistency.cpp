// Filter consistency (NEES over Monte-Carlo runs) on simulated flights, and the simulator's
// own kinematics against finite differences.
#include <gtest/gtest.h>

#include "kestrel/fusion/simulation.hpp"

namespace kestrel::fusion {
namespace {

TEST(FusionSimulation, FlightDerivativesMatchFiniteDifferences) {
  for (std::uint64_t seed = 1; seed < 6; ++seed) {
    const SimulatedFlight flight(seed);
    for (double t = 0.0; t < 20.0; t += 3.7) {
      const double h = 1e-5;
      const FlightPoint p = flight.at(t), a = flight.at(t - h), b = flight.at(t + h);
      EXPECT_LT((p.v_world - (b.T_world_body.translation() - a.T_world_body.translation()) / (2 * h)).norm(), 1e-6);
      EXPECT_LT((p.a_world - (b.v_world - a.v_world) / (2 * h)).norm(), 1e-6);
      // omega_body = log(R(t-h)^T R(t+h)) / 2h
      const Eigen::Vector3d w = (a.T_world_body.so3().inverse() * b.T_world_body.so3()).log() / (2 * h);
      EXPECT_LT((p.omega_body - w).norm(), 1e-6);
    }
  }
}

TEST(FusionConsistency, MonteCarloNeesInsideTheBounds) {
  // Small for the test suite (the figures in docs/fusion.md use 50 runs x 30 s at 200 Hz).
  SimulationOptions sim;
  sim.duration_s = 8.0;
  sim.imu_rate_hz = 100.0;
  const NeesResult r = monte_carlo_nees(20, sim, FusionOptions{}, 42);
  ASSERT_EQ(r.t_s.size(), 160u);
  // The time average of the run-averaged NEES (160 x 20 x 3 dof) is far tighter than the
  // per-step bounds; require it inside the per-step 95 % bounds.
  for (double m : {r.mean_p, r.mean_theta, r.mean_v}) {
    EXPECT_GT(m, r.lower_bound);
    EXPECT_LT(m, r.upper_bound);
  }
  EXPECT_GT(r.inside_p, 0.8);
  EXPECT_GT(r.inside_theta, 0.8);
  EXPECT_GT(r.inside_v, 0.8);
}

}  // namespace
}  // namespace kestrel::fusion
