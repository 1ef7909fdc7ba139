// The fusion's defences against bad input: IMU samples beyond the sensor's range or repeating
// a time stamp are rejected and counted, odometry outside the IMU's time coverage is refused
// beyond the horizon instead of being reached on a held IMU reading, and an implausible state
// is flagged. Each known answer is checked against the same run without the defence.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/fusion_engine.hpp"

namespace kestrel::fusion::guard_test {
namespace {

using Eigen::Vector3d;

constexpr TimeNs kPeriod = 5'000'000;  // 200 Hz
constexpr TimeNs kSecond = 1'000'000'000;

// A body at rest with identity attitude for `seconds`, odometry "no motion" at 20 Hz.
struct Scenario {
  std::vector<io::ImuSample> imu;
  std::vector<RelativePoseMeasurement> vo;
};
Scenario still_scenario(double seconds) {
  Scenario s;
  const auto n = static_cast<int>(seconds * 200);
  for (int k = 0; k <= n; ++k) {
    io::ImuSample x;
    x.t_ns = k * kPeriod;
    x.accel_m_s2 = Vector3d(0, 0, 9.81);
    s.imu.push_back(x);
  }
  for (int k = 10; k <= n; k += 10) {
    RelativePoseMeasurement m;
    m.t_ref_ns = (k - 10) * kPeriod;
    m.t_ns = k * kPeriod;
    m.covariance = Vector6d::Constant(1e-4).asDiagonal();
    s.vo.push_back(m);
  }
  return s;
}

std::vector<FusedState> run(FusionEngine& e, const Scenario& sc, bool imu_rate) {
  for (const auto& s : sc.imu) e.add_imu(s);
  for (const auto& m : sc.vo) e.add_relative_pose(m);
  return e.flush(imu_rate);
}

double worst_distance(const std::vector<FusedState>& a, const std::vector<FusedState>& b) {
  double worst = 0.0;
  std::size_t j = 0;
  for (const auto& f : a) {
    while (j < b.size() && b[j].t_ns < f.t_ns) ++j;
    if (j < b.size() && b[j].t_ns == f.t_ns) {
      worst = std::max(worst, (f.state.p_world - b[j].state.p_world).norm());
    }
  }
  return worst;
}

// One accelerometer value of 1e3 m/s^2 (102 g) in a still IMU: rejected as beyond the default
// +-16 g, and the fused trajectory stays on the clean one. With the range opened up the same
// sample moves the estimate by decimetres: the known answer depends on the check.
TEST(FusionGuards, SpikedImuSampleIsRejectedAndTheTrajectoryStaysOnTheCleanOne) {
  const Scenario clean = still_scenario(6.0);
  Scenario spiked = clean;
  spiked.imu[600].accel_m_s2.x() = 1e3;  // at 3 s, after the static initialisation

  FusionEngine e_clean{FusionOptions{}}, e_spiked{FusionOptions{}};
  const auto out_clean = run(e_clean, clean, false);
  const auto out_spiked = run(e_spiked, spiked, false);
  ASSERT_EQ(out_clean.size(), out_spiked.size());
  EXPECT_EQ(e_spiked.counters().imu_out_of_range, 1u);
  EXPECT_EQ(e_clean.counters().imu_out_of_range, 0u);
  EXPECT_NE(
      e_spiked.counters().describe_rejections().find("1 IMU samples beyond the sensor's range"),
      std::string::npos)
      << e_spiked.counters().describe_rejections();
  // The still IMU reads the same on both sides of the missing sample: the same trajectory.
  EXPECT_LT(worst_distance(out_clean, out_spiked), 1e-6);
  EXPECT_LT(out_spiked.back().state.p_world.norm(), 1e-3);

  FusionOptions open;
  open.accel_range_m_s2 = 1e6;
  FusionEngine e_open{open};
  const auto out_open = run(e_open, spiked, false);
  EXPECT_EQ(e_open.counters().imu_out_of_range, 0u);
  EXPECT_GT(worst_distance(out_clean, out_open), 0.05);
}

// The range comes from the sensor YAML where it has one; a gyro beyond it is rejected too.
TEST(FusionGuards, RangeFromTheSensorFileRejectsTheGyroBeyondIt) {
  io::ImuNoise sensor;
  sensor.gyro_noise_density = 1e-4;
  sensor.gyro_random_walk = 1e-5;
  sensor.accel_noise_density = 1e-3;
  sensor.accel_random_walk = 1e-3;
  sensor.gyro_range_rad_s = 5.0;
  FusionOptions o;
  o.set_imu_noise(sensor);
  EXPECT_EQ(o.gyro_range_rad_s, 5.0);
  EXPECT_EQ(o.accel_range_m_s2, FusionOptions{}.accel_range_m_s2);  // not in this file
  io::ImuSample s;
  s.accel_m_s2 = Vector3d(0, 0, 9.81);
  s.gyro_rad_s = Vector3d(0, -4.9, 0);
  EXPECT_TRUE(imu_sample_in_range(s, o));
  s.gyro_rad_s.y() = -5.1;
  EXPECT_FALSE(imu_sample_in_range(s, o));
  EXPECT_TRUE(imu_sample_in_range(s, FusionOptions{}));  // 5.1 rad/s is within 2000 deg/s
  FusionEngine e{o};
  e.add_imu(s);
  EXPECT_EQ(e.counters().imu_out_of_range, 1u);
}

TEST(FusionGuards, RepeatedTimeStampIsCountedNotPropagated) {
  Scenario sc = still_scenario(3.0);
  io::ImuSample repeat = sc.imu[500];
  repeat.accel_m_s2.x() = 50.0;  // within the range, but a second reading of one instant
  sc.imu.insert(sc.imu.begin() + 501, repeat);
  FusionEngine e{FusionOptions{}};
  const auto out = run(e, sc, true);
  EXPECT_EQ(e.counters().imu_duplicate, 1u);
  EXPECT_LT(e.filter().state().p_world.norm(), 1e-3);
  // One IMU-rate output per distinct sample after the static start at 1 s (samples 201..600).
  std::size_t imu_outputs = 0;
  for (const auto& f : out) imu_outputs += f.at_odometry ? 0 : 1;
  EXPECT_EQ(imu_outputs, 400u);
}

// The IMU ends at 3 s, the odometry runs to 6 s: measurements more than the horizon (0.5 s)
// after the last IMU sample are refused with no output, so nothing is reached on a held IMU
// reading for longer than the horizon.
TEST(FusionGuards, OdometryPastTheEndOfTheImuIsRefusedBeyondTheHorizon) {
  Scenario sc = still_scenario(6.0);
  sc.imu.resize(601);  // 0 .. 3 s
  // A bias on the held reading: extrapolated over 3 s it would move the estimate by metres.
  sc.imu.back().accel_m_s2.x() = 2.0;
  FusionEngine e{FusionOptions{}};
  const auto out = run(e, sc, false);
  const TimeNs imu_end = 3 * kSecond;
  const TimeNs horizon = s_to_ns(FusionOptions{}.imu_horizon_s);
  ASSERT_FALSE(out.empty());
  EXPECT_LE(out.back().t_ns, imu_end + horizon);
  std::size_t beyond = 0;
  for (const auto& m : sc.vo) beyond += m.t_ns > imu_end + horizon ? 1 : 0;
  EXPECT_EQ(beyond, 50u);  // 3.55 .. 6 s
  EXPECT_EQ(e.counters().measurements_outside_imu, beyond);
  EXPECT_NE(e.counters().describe_rejections().find("outside the IMU's time coverage"),
            std::string::npos);
  // A shorter horizon refuses more; a longer one lets the odometry through to its end.
  FusionOptions longer;
  longer.imu_horizon_s = 10.0;
  FusionEngine e_long{longer};
  const auto out_long = run(e_long, sc, false);
  EXPECT_EQ(e_long.counters().measurements_outside_imu, 0u);
  EXPECT_EQ(out_long.back().t_ns, 6 * kSecond);
  EXPECT_GT(out_long.back().state.p_world.norm(), out.back().state.p_world.norm());
}

// A given initial state at 0 s and an IMU that starts only at 2 s: the odometry before the IMU
// is refused, and the late start is counted as a gap beyond the horizon.
TEST(FusionGuards, OdometryBeforeALateImuStartIsRefused) {
  Scenario sc = still_scenario(4.0);
  sc.imu.erase(sc.imu.begin(), sc.imu.begin() + 400);  // IMU from 2 s
  FusionEngine e{FusionOptions{}};
  NominalState x0;
  x0.t_ns = 0;
  e.initialize(x0);
  const auto out = run(e, sc, false);
  EXPECT_EQ(e.counters().measurements_outside_imu, 39u);  // 0.05 .. 1.95 s
  EXPECT_EQ(e.counters().imu_gaps_beyond_horizon, 1u);
  ASSERT_FALSE(out.empty());
  EXPECT_GE(out.front().t_ns, 2 * kSecond);
}

// A state far beyond a MAV (a 10 g push held for 1 s: 98 m/s) is flagged implausible; the
// same flight at 1 g is not.
TEST(FusionGuards, ImplausibleSpeedIsFlaggedAndCounted) {
  auto fly = [](double accel_m_s2) {
    Scenario sc = still_scenario(3.0);
    sc.vo.clear();
    for (std::size_t k = 400; k < sc.imu.size(); ++k) sc.imu[k].accel_m_s2.x() = accel_m_s2;
    FusionEngine e{FusionOptions{}};
    const auto out = run(e, sc, true);
    std::size_t flagged = 0;
    for (const auto& f : out) flagged += (f.flags & kFlagImplausible) ? 1 : 0;
    EXPECT_EQ(flagged, e.counters().implausible_outputs);
    return e;
  };
  const FusionEngine fast = fly(98.0);
  EXPECT_GT(fast.counters().implausible_outputs, 0u);
  ASSERT_TRUE(fast.first_implausible().has_value());
  EXPECT_NE(fast.first_implausible()->second.find("speed"), std::string::npos);
  EXPECT_GT(fast.first_implausible()->first.state.v_world.norm(), FusionOptions{}.max_speed_m_s);
  const FusionEngine slow = fly(9.8);
  EXPECT_EQ(slow.counters().implausible_outputs, 0u);
  EXPECT_FALSE(slow.first_implausible().has_value());
}

// A position step that no speed explains (an odometry jump of 3 m in one frame, trusted to
// 0.1 mm with the gate off) is flagged at the output after the update, which has the same time
// as the IMU-rate output before it; the same run without the jump is not.
TEST(FusionGuards, PositionJumpIsFlagged) {
  FusionOptions no_gate;
  no_gate.gate_probability = 0.0;
  const Scenario clean = still_scenario(3.0);
  Scenario jump = clean;
  for (auto& m : jump.vo) {
    if (m.t_ns == 2 * kSecond) {
      m.T_ref_cur = SE3(SO3(), Vector3d(3.0, 0, 0));
      m.covariance = Vector6d::Constant(1e-8).asDiagonal();
    }
  }
  FusionEngine e_clean{no_gate}, e_jump{no_gate};
  (void)run(e_clean, clean, true);
  EXPECT_EQ(e_clean.counters().implausible_outputs, 0u);
  (void)run(e_jump, jump, true);
  EXPECT_GT(e_jump.counters().implausible_outputs, 0u);
  ASSERT_TRUE(e_jump.first_implausible().has_value());
  EXPECT_EQ(e_jump.first_implausible()->first.t_ns, 2 * kSecond);
  EXPECT_NE(e_jump.first_implausible()->second.find("position moved"), std::string::npos)
      << e_jump.first_implausible()->second;
}

TEST(FusionGuards, OptionsOutsideTheirSenseAreRefused) {
  for (auto set : {+[](FusionOptions& o) { o.imu_horizon_s = 0.0; },
                   +[](FusionOptions& o) { o.accel_range_m_s2 = -1.0; },
                   +[](FusionOptions& o) { o.gyro_range_rad_s = std::nan(""); },
                   +[](FusionOptions& o) { o.max_speed_m_s = 0.0; },
                   +[](FusionOptions& o) { o.max_position_jump_m = -2.0; }}) {
    FusionOptions o;
    set(o);
    EXPECT_THROW(o.validate(), InputError);
  }
}

}  // namespace
}  // namespace kestrel::fusion::guard_test
