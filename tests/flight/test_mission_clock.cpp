// The mission clock: exact while the mission runs, a continuous brake along the path in a
// hold and a continuous start when the mission resumes (what the IMU hold flies).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "kestrel/flight/mission_clock.hpp"

namespace kestrel::flight {
namespace {

constexpr double kDt = 0.005;  // the flight's control period

// A straight 10 m leg at 0.5 m/s after a 1 s ramp: cruising from 1 s to 20.5 s.
WaypointPath leg() { return WaypointPath({{0, 0, 1}, {10, 0, 1}}, 0.0, 0.5, 0.5, 0.0); }

TEST(MissionClock, RunningIsTheFlightsTime) {
  MissionClock clock(0.25);
  for (int k = 0; k <= 2000; ++k) {
    const double t = k * kDt;
    clock.advance(t, true);
    ASSERT_EQ(clock.time_s(), t);
    ASSERT_EQ(clock.rate(), 1.0);
  }
  const ReferencePath path(leg());
  EXPECT_TRUE(clock.reference(path).p_world.isApprox(path.at(10.0).p_world));
  EXPECT_THROW(MissionClock(0.0), std::invalid_argument);
}

// A hold from a steady cruise: the rate is (1 + t/T) e^(-t/T), the mission stops ~2 T of
// mission time later, and neither the reference's velocity nor its acceleration steps; the
// same when the mission resumes.
TEST(MissionClock, HoldBrakesAndResumeStartsWithoutSteps) {
  const double T = 0.25;
  MissionClock clock(T);
  const ReferencePath path(leg());
  double t = 0.0;
  auto run = [&](double until, bool running, auto&& each) {
    for (; t < until - 1e-12;) {
      const control::PositionReference before = clock.reference(path);
      t += kDt;
      clock.advance(t, running);
      const control::PositionReference after = clock.reference(path);
      // At 0.5 m/s: the largest change of the eased velocity (0.74 m/s^2) and acceleration
      // (0.5 / T^2 m/s^3) in one step, with a margin; a stop would step them by 0.5 m/s and
      // (eased in first order) 0.5 / T m/s^2.
      EXPECT_LT((after.v_world - before.v_world).norm(), kDt / T) << t;
      EXPECT_LT((after.a_world - before.a_world).norm(), kDt / (T * T)) << t;
      EXPECT_GE(clock.rate(), 0.0);
      EXPECT_LE(clock.rate(), 1.0);
      each();
    }
  };
  // Up to the cruise (the path's own acceleration steps at its ramp's end, 1 s).
  for (; t < 2.0 - 1e-12; t += kDt) clock.advance(t, true);
  run(3.0, true, [] {});
  const double held_at = clock.time_s();
  run(3.5, false, [&] {
    const double s = (t - 3.0) / T;
    EXPECT_NEAR(clock.rate(), (1.0 + s) * std::exp(-s), 1e-9) << t;
  });
  run(6.0, false, [] {});
  EXPECT_NEAR(clock.time_s() - held_at, 2.0 * T, 0.01);
  EXPECT_LT(clock.reference(path).v_world.norm(), 1e-3);
  const double stopped_at = clock.time_s();
  run(9.0, true, [] {});
  EXPECT_NEAR(clock.rate(), 1.0, 1e-3);  // 1 - 13 e^-12 after 12 T
  // The resume costs 2 T of mission time, like the brake.
  EXPECT_NEAR(clock.time_s() - stopped_at, 3.0 - 2.0 * T, 0.01);
  // A short hold that ends while braking: still no step, never backwards.
  run(9.1, false, [] {});
  run(12.0, true, [] {});
  EXPECT_NEAR(clock.rate(), 1.0, 1e-3);
}

}  // namespace
}  // namespace kestrel::flight
