// The position controller's rejection of a step of wind (a constant force switched on in
// hover), on perfect state (closed_loop.hpp): the velocity integral must take the error back
// to near zero within a few seconds, where a proportional-only loop keeps an offset of
// a / (k_p k_v).
#include <gtest/gtest.h>

#include "closed_loop.hpp"

namespace kestrel::test {
namespace {

struct StepResponse {
  double peak_m = 0.0;     // largest error after the step
  double settled_m = 0.0;  // largest error from 4 s after the step to the end
};

StepResponse wind_step(const control::PositionControllerOptions& options,
                       const Eigen::Vector3d& force) {
  const Eigen::Vector3d p(0.0, 0.0, 1.5);
  ClosedLoop loop(hover_at(p), options);
  loop.reference = [p](double) { return point(p); };
  loop.run(5.0);  // settle
  loop.vehicle.quadrotor().set_external_force_world(force);
  const auto log = loop.run(8.0);
  StepResponse r;
  for (const LoopSample& s : log) {
    const double e = (s.p_true - s.p_ref).norm();
    r.peak_m = std::max(r.peak_m, e);
    if (s.t_s >= 5.0 + 4.0) r.settled_m = std::max(r.settled_m, e);
    EXPECT_FALSE(s.crashed);
  }
  return r;
}

TEST(DisturbanceRejection, AStepOfWindIsRejectedByTheVelocityIntegral) {
  // 1.5 N horizontal and 1 N down on the 1.2 kg vehicle: a 2.4 m/s breeze's drag on this
  // frame (0.30 v + 0.09 v^2) plus a downdraft.
  const Eigen::Vector3d force(1.5, 0.0, -1.0);
  // The integral alone (the observer has its own test, test_disturbance_observer.cpp).
  control::PositionControllerOptions nominal;
  nominal.disturbance_observer = false;
  const StepResponse with = wind_step(nominal, force);
  EXPECT_LT(with.peak_m, 0.25);
  EXPECT_LT(with.settled_m, 0.04) << "the error did not return within 4 s";

  // Without the integral the offset stays: a / (k_p k_v) = 1.25 / (1.4 * 3) = 0.30 m sideways.
  // (The gain before issue 29's world, 0.8 /s^2, left 0.12 m after 4 s: it fails the bound.)
  control::PositionControllerOptions no_integral = nominal;
  no_integral.velocity_integral_gain_xy = 0.0;
  const StepResponse without = wind_step(no_integral, Eigen::Vector3d(1.5, 0.0, 0.0));
  EXPECT_GT(without.settled_m, 0.2);
}

}  // namespace
}  // namespace kestrel::test
