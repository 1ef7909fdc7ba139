// The flight-controller model: RC decoding, attitude tracking of stick commands, yaw rate.
#include <gtest/gtest.h>

#include <cmath>

#include "kestrel/core/units.hpp"
#include "kestrel/sim/simulated_vehicle.hpp"

namespace kestrel::sim {
namespace {

control::PwmChannels sticks(int roll, int pitch, int throttle, int yaw) {
  control::PwmChannels p;
  p.us = {roll, pitch, throttle, yaw};
  return p;
}

int hover_throttle_us(const QuadrotorParameters& p) {
  return 1000 + static_cast<int>(std::lround(1000.0 * p.hover_thrust_N() / p.max_thrust_N()));
}

TEST(FlightControllerModel, DecodesPulsesWithDeadbandAndLimits) {
  const FlightControllerModel fc({}, {});
  auto d = fc.decode(sticks(1505, 1492, 1000, 2100));
  EXPECT_EQ(d.roll, 0.0);
  EXPECT_EQ(d.pitch, 0.0);
  EXPECT_TRUE(d.idle);
  EXPECT_EQ(d.yaw, 1.0);
  d = fc.decode(sticks(1500 + 8 + 246, 1000, 1500, 1500));
  EXPECT_NEAR(d.roll, 0.5, 1e-12);
  EXPECT_EQ(d.pitch, -1.0);
  EXPECT_NEAR(d.throttle, 0.5, 1e-12);
  EXPECT_FALSE(d.idle);
}

TEST(FlightControllerModel, TracksARollStepWithinAFewTenthsOfASecond) {
  const QuadrotorParameters p;
  SimulatedVehicle v(p, {}, Quadrotor::hover_state(p, {0, 0, 10}));
  // Half right roll stick: 22.5 deg.
  const auto cmd = sticks(1500 + 8 + 246, 1500, hover_throttle_us(p), 1500);
  double peak = 0.0;
  double at_03 = 0.0;
  for (int i = 0; i < 1000; ++i) {
    v.step(0.001, cmd);
    const Eigen::Vector3d z = v.state().R_world_body * Eigen::Vector3d::UnitZ();
    const double roll = std::asin(-z.y());  // positive roll tilts thrust to -y
    peak = std::max(peak, roll);
    if (i == 299) at_03 = roll;
  }
  const Eigen::Vector3d z = v.state().R_world_body * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(std::asin(-z.y()), 22.5 * kDegToRad, 0.5 * kDegToRad);
  EXPECT_NEAR(at_03, 22.5 * kDegToRad, 2.0 * kDegToRad);
  EXPECT_LT(peak, 22.5 * kDegToRad * 1.15) << "overshoot";
  EXPECT_LT(v.state().v_world.y(), -1.0) << "rolling right accelerates towards -y";
}

TEST(FlightControllerModel, YawStickGivesTheRatedRate) {
  const QuadrotorParameters p;
  SimulatedVehicle v(p, {}, Quadrotor::hover_state(p, {0, 0, 10}));
  // Full left rudder: counter-clockwise at 200 deg/s (table C.3).
  for (int i = 0; i < 1000; ++i) v.step(0.001, sticks(1500, 1500, hover_throttle_us(p), 1000));
  EXPECT_NEAR(v.state().omega_body.z(), 200.0 * kDegToRad, 10.0 * kDegToRad);
  EXPECT_NEAR(v.state().p_world.z(), 10.0, 0.2);
}

TEST(FlightControllerModel, IdleThrottleKeepsTheVehicleOnTheGround) {
  const QuadrotorParameters p;
  QuadrotorState ground;
  SimulatedVehicle v(p, {}, ground);
  for (int i = 0; i < 500; ++i) v.step(0.001, sticks(2000, 2000, 1040, 2000));
  EXPECT_TRUE(v.state().on_ground);
  EXPECT_EQ(v.state().p_world.z(), 0.0);
}

}  // namespace
}  // namespace kestrel::sim
