#include "kestrel/core/units.hpp"
// Safety behaviours, each in closed loop on the simulated vehicle: odometry loss (hold on the
// IMU, recover; or land after the timeout), estimator failure (level open-loop descent),
// the command watchdog (controller hangs: level, descend, cut off), command bounds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "closed_loop.hpp"

namespace kestrel::control {
namespace {

using test::ClosedLoop;
using test::hover_at;
using test::point;

// Odometry silent in [from, to) seconds.
std::function<EstimatorHealth(TimeNs)> vision_gap(double from_s, double to_s) {
  return [=](TimeNs t) {
    EstimatorHealth h;
    const double ts = ns_to_s(t);
    h.last_vision_update_ns = (ts >= from_s && ts < to_s) ? s_to_ns(from_s) : t;
    return h;
  };
}

TEST(Safety, OdometryLossFor2sHoldsAndRecovers) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  // Flying towards x = 1 m when the odometry drops out at t = 4 s for 2 s.
  loop.reference = [](double t) { return point({t < 3.0 ? 0.0 : 1.0, 0.0, 1.5}); };
  loop.health = vision_gap(4.0, 6.0);
  const auto log = loop.run(12.0);
  bool held = false;
  for (const auto& s : log) {
    if (s.t_s > 4.35 && s.t_s < 5.9) {
      EXPECT_EQ(s.mode, SafetyMode::kImuHold) << s.t_s;
      held = true;
    }
    if (s.t_s > 6.1) {
      EXPECT_EQ(s.mode, SafetyMode::kNominal) << s.t_s;
    }
  }
  EXPECT_TRUE(held);
  const Eigen::Vector3d final_err = log.back().p_true - Eigen::Vector3d(1, 0, 1.5);
  std::printf("[figure] 2 s odometry gap: final error %.4f m, crashed %d\n", final_err.norm(),
              log.back().crashed ? 1 : 0);
  EXPECT_LT(final_err.norm(), 0.01);
  EXPECT_FALSE(log.back().crashed);
}

TEST(Safety, LongOdometryLossLandsAfterTheTimeout) {
  ClosedLoop loop(hover_at({0.5, 0.5, 1.5}));
  loop.reference = [](double) { return point({0.5, 0.5, 1.5}); };
  loop.health = vision_gap(1.0, 1e9);
  const auto log = loop.run(14.0);
  double landing_start = -1.0, landed_at = -1.0;
  for (const auto& s : log) {
    if (landing_start < 0 && s.mode == SafetyMode::kLanding) landing_start = s.t_s;
    if (landed_at < 0 && s.mode == SafetyMode::kLanded) landed_at = s.t_s;
  }
  const auto& st = loop.vehicle.state();
  std::printf(
      "[figure] odometry lost: landing at %.2f s, landed at %.2f s, touchdown %.2f m/s, "
      "drift %.3f m\n",
      landing_start, landed_at, st.touchdown_speed_m_s,
      (st.p_world.head<2>() - Eigen::Vector2d(0.5, 0.5)).norm());
  EXPECT_NEAR(landing_start, 1.0 + 0.3 + 5.0, 0.05);
  EXPECT_GT(landed_at, landing_start);
  EXPECT_TRUE(st.on_ground);
  EXPECT_FALSE(st.crashed);
  EXPECT_LT(st.touchdown_speed_m_s, 0.6);
  EXPECT_LT((st.p_world.head<2>() - Eigen::Vector2d(0.5, 0.5)).norm(), 0.05);
  EXPECT_EQ(loop.output.latest().us[PwmChannels::kThrottle], 1000) << "motors off once landed";
}

TEST(Safety, EstimatorFailureDescendsLevelAndCutsTheMotors) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  loop.reference = [](double) { return point({0, 0, 1.5}); };
  loop.health = [](TimeNs t) {
    EstimatorHealth h;
    h.last_vision_update_ns = t;
    h.estimate_valid = ns_to_s(t) < 3.0;  // the filter diverges at 3 s
    return h;
  };
  const auto log = loop.run(16.0);
  double max_tilt = 0.0;
  for (const auto& s : log) {
    if (s.t_s > 3.0) {
      EXPECT_TRUE(s.mode == SafetyMode::kBlindDescent || s.mode == SafetyMode::kLanded) << s.t_s;
      max_tilt = std::max(max_tilt, std::hypot(s.command.roll_rad, s.command.pitch_rad));
    }
  }
  const auto& st = loop.vehicle.state();
  std::printf("[figure] estimator failure: touchdown %.2f m/s, drift %.3f m\n",
              st.touchdown_speed_m_s, st.p_world.head<2>().norm());
  EXPECT_EQ(max_tilt, 0.0) << "level";
  EXPECT_TRUE(st.on_ground);
  EXPECT_FALSE(st.crashed);
  EXPECT_LT(st.touchdown_speed_m_s, 1.5);
  EXPECT_EQ(log.back().mode, SafetyMode::kLanded);
  EXPECT_EQ(loop.output.latest().us[PwmChannels::kThrottle], 1000);
}

TEST(Safety, WatchdogLevelsAndDescendsWhenCommandsStop) {
  ClosedLoop loop(hover_at({0, 0, 1.5}));
  // Flying sideways at 0.5 m/s when the controller hangs at t = 4 s.
  loop.reference = [](double t) {
    PositionReference r;
    r.p_world = {0.5 * t, 0, 1.5};
    r.v_world = {0.5, 0, 0};
    return r;
  };
  loop.controller_alive = [](double t) { return t < 4.0; };
  const auto log = loop.run(14.0);
  double tripped_at = -1.0, cut_at = -1.0;
  for (const auto& s : log) {
    if (tripped_at < 0 && s.watchdog == WatchdogState::kTripped) tripped_at = s.t_s;
    if (cut_at < 0 && s.watchdog == WatchdogState::kCutOff) cut_at = s.t_s;
    if (s.watchdog == WatchdogState::kTripped) {
      EXPECT_EQ(s.command.roll_rad, 0.0);
      EXPECT_EQ(s.command.pitch_rad, 0.0);
      EXPECT_LT(s.command.thrust_N, 1.2 * kGravity);
    }
  }
  const auto& st = loop.vehicle.state();
  std::printf(
      "[figure] watchdog: tripped %.3f s after the last command, cut off at %.2f s, "
      "touchdown %.2f m/s\n",
      tripped_at - 4.0 + 0.005, cut_at, st.touchdown_speed_m_s);
  EXPECT_NEAR(tripped_at, 4.25, 0.01);
  EXPECT_NEAR(cut_at, 4.0 + 0.25 + 8.0, 0.01);
  EXPECT_TRUE(st.on_ground);
  EXPECT_FALSE(st.crashed);
  EXPECT_LT(st.touchdown_speed_m_s, 1.5);
  EXPECT_EQ(loop.output.latest().us[PwmChannels::kThrottle], 1000);
}

TEST(CommandWatchdog, PassesFreshCommandsAndNeedsARearmAfterACutOff) {
  CommandWatchdog w;
  EXPECT_TRUE(w.output(0).motors_off) << "nothing commanded yet";
  AttitudeThrustCommand c{0.1, -0.1, 0.2, 12.0};
  w.submit(0, c);
  auto out = w.output(100'000'000);
  EXPECT_EQ(out.state, WatchdogState::kActive);
  EXPECT_EQ(out.command.roll_rad, 0.1);
  out = w.output(300'000'000);
  EXPECT_EQ(out.state, WatchdogState::kTripped);
  out = w.output(9'000'000'000);
  EXPECT_EQ(out.state, WatchdogState::kCutOff);
  w.submit(9'000'000'000, c);
  EXPECT_EQ(w.output(9'001'000'000).state, WatchdogState::kCutOff);
  w.rearm();
  w.submit(9'002'000'000, c);
  EXPECT_EQ(w.output(9'003'000'000).state, WatchdogState::kActive);
}

TEST(BoundCommand, ClipsAndReplacesNonFiniteValues) {
  const CommandLimits l;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto b = bound_command({nan, 2.0, -10.0, nan}, l, 11.0);
  EXPECT_TRUE(b.non_finite);
  EXPECT_TRUE(b.clipped);
  EXPECT_EQ(b.command.roll_rad, 0.0);
  EXPECT_NEAR(b.command.pitch_rad, 35 * kDegToRad, 1e-12);
  EXPECT_NEAR(b.command.yaw_rate_rad_s, -120 * kDegToRad, 1e-12);
  EXPECT_EQ(b.command.thrust_N, 11.0);
  b = bound_command({0.1, 0.1, 0.1, 12.0}, l, 11.0);
  EXPECT_FALSE(b.clipped || b.non_finite);
}

TEST(SafetySupervisor, TouchdownAtTheMissionsEndSwitchesTheMotorsOffButNotBeforeTakeOff) {
  SafetySupervisor s;
  EstimatorHealth h;
  PositionReference on_ground;  // z = 0: the floor
  VehicleStateEstimate e;
  TimeNs t = 0;
  auto step = [&](double z) {
    e.p_world.z() = z;
    h.last_vision_update_ns = t;
    const auto d = s.update(t, e, h, on_ground, 11.8);
    t += s_to_ns(0.005);
    return d;
  };
  // Standing before take-off with the mission still on the ground: never "landed".
  for (int k = 0; k < 1000; ++k) EXPECT_EQ(step(0.0).mode, SafetyMode::kNominal);
  // Flies (the mission's reference in the air: no touchdown even when low), ...
  PositionReference up;
  up.p_world.z() = 1.0;
  for (int k = 0; k < 400; ++k) {
    e.p_world.z() = 1.0;
    h.last_vision_update_ns = t;
    EXPECT_EQ(s.update(t, e, h, up, 11.8).mode, SafetyMode::kNominal);
    t += s_to_ns(0.005);
  }
  // ... comes back down: after landed_hold_s low and still on a mission on the ground, off.
  SafetyDecision d;
  for (int k = 0; k < 190; ++k) {
    d = step(0.02);
    EXPECT_EQ(d.mode, SafetyMode::kNominal) << k;
  }
  for (int k = 0; k < 20 && d.mode != SafetyMode::kLanded; ++k) d = step(0.02);
  EXPECT_EQ(d.mode, SafetyMode::kLanded);
  EXPECT_TRUE(d.motors_off);
  EXPECT_NEAR(d.reference.p_world.z(), 0.0, 1e-12);  // the mission's landing point
}

TEST(SafetySupervisor, NonFiniteEstimateIsAFailure) {
  SafetySupervisor s;
  VehicleStateEstimate e;
  e.p_world.x() = std::numeric_limits<double>::quiet_NaN();
  EstimatorHealth h;
  const auto d = s.update(0, e, h, PositionReference{}, 11.8);
  EXPECT_EQ(d.mode, SafetyMode::kBlindDescent);
  ASSERT_TRUE(d.override_command.has_value());
  EXPECT_NEAR(d.override_command->thrust_N, 0.95 * 11.8, 1e-12);
  EXPECT_FALSE(d.reason.empty());
}

// hold_flies_mission: the IMU hold flies the mission reference it is handed (which its caller
// brings to rest) instead of a fixed point at the estimate, and a landing after the hold's
// timeout starts below the last of it; off, the hold is the estimate's position at rest.
TEST(SafetySupervisor, HoldFliesTheMissionWhenAsked) {
  auto hold = [](bool flies_mission) {
    SafetyOptions o;
    o.hold_flies_mission = flies_mission;
    SafetySupervisor s(o);
    EstimatorHealth h;  // the last vision update at t = 0
    VehicleStateEstimate e;
    e.p_world = {0.0, 0.0, 1.0};
    e.v_world = {0.5, 0.0, 0.0};
    std::vector<SafetyDecision> log;
    for (int k = 0; k * 0.005 < o.imu_hold_timeout_s + 1.0; ++k) {
      PositionReference mission;  // braking along x to a stop at 0.25 m
      const double t = k * 0.005;
      mission.p_world = {0.25 * (1.0 - std::exp(-4.0 * t)), 0.0, 1.0};
      mission.v_world = {std::exp(-4.0 * t), 0.0, 0.0};
      log.push_back(s.update(s_to_ns(t), e, h, mission, 11.8));
      e.p_world.x() = mission.p_world.x();
      if (flies_mission && log.back().mode != SafetyMode::kLanding) {
        EXPECT_TRUE(log.back().reference.p_world.isApprox(mission.p_world)) << k;
      }
    }
    return log;
  };
  const auto flies = hold(true);
  const auto fixed = hold(false);
  bool held = false;
  for (std::size_t k = 0; k < flies.size(); ++k) {
    if (flies[k].mode != SafetyMode::kImuHold) continue;
    held = true;
    EXPECT_GT(flies[k].reference.v_world.x(), 0.0) << k;  // the mission's feed-forward
    EXPECT_EQ(fixed[k].reference.v_world.norm(), 0.0) << k;
  }
  EXPECT_TRUE(held);
  ASSERT_EQ(flies.back().mode, SafetyMode::kLanding);
  ASSERT_EQ(fixed.back().mode, SafetyMode::kLanding);
  EXPECT_NEAR(flies.back().reference.p_world.x(), 0.25, 1e-6);  // where the mission stopped
  EXPECT_LT(fixed.back().reference.p_world.x(), 0.25 * (1.0 - std::exp(-4.0 * 0.31)));
}

}  // namespace
}  // namespace kestrel::control
