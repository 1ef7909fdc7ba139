// PWM mapping (scaling, deadband, direction, hard limits, inverse) and the output backends:
// simulated, sysfs (on a temporary directory laid out like a pwmchip), serial MSP (on a
// pseudo-terminal).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <pty.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/pwm_output.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/sim/flight_controller_model.hpp"
#include "test_data.hpp"

namespace kestrel::control {
namespace {

TEST(PwmMapper, NeutralHoverAndFullScale) {
  const PwmMapper m;
  AttitudeThrustCommand c;
  c.thrust_N = 14.0;  // half of 28 N
  auto p = m.map(c);
  EXPECT_EQ(p.us[PwmChannels::kRoll], 1500);
  EXPECT_EQ(p.us[PwmChannels::kPitch], 1500);
  EXPECT_EQ(p.us[PwmChannels::kYaw], 1500);
  EXPECT_EQ(p.us[PwmChannels::kThrottle], 1500);
  c.roll_rad = 45 * kDegToRad;
  c.pitch_rad = -45 * kDegToRad;
  c.yaw_rate_rad_s = 200 * kDegToRad;  // counter-clockwise: rudder left
  p = m.map(c);
  EXPECT_EQ(p.us[PwmChannels::kRoll], 2000);
  EXPECT_EQ(p.us[PwmChannels::kPitch], 1000);
  EXPECT_EQ(p.us[PwmChannels::kYaw], 1000);
}

TEST(PwmMapper, SmallCommandsJumpTheDeadband) {
  const PwmMapper m;
  AttitudeThrustCommand c;
  c.thrust_N = 12.0;
  c.roll_rad = 0.1 * kDegToRad;
  const auto p = m.map(c);
  EXPECT_GT(p.us[PwmChannels::kRoll], 1500 + 8);
  // And the flight controller reads back what was meant.
  const sim::FlightControllerModel fc({}, {});
  EXPECT_NEAR(fc.decode(p).roll * 45.0, 0.1, 0.1);
}

TEST(PwmMapper, HardLimitsHoldForAnyInput) {
  PwmMapperOptions o;
  o.channels[PwmChannels::kRoll].min_us = 1100;
  o.channels[PwmChannels::kRoll].max_us = 1900;
  const PwmMapper m(o);
  const double inf = std::numeric_limits<double>::infinity();
  for (double v : {-1e9, -1.0, 0.0, 1.0, 1e9, inf, -inf, std::nan("")}) {
    AttitudeThrustCommand c{v, v, v, v};
    const auto p = m.map(c);
    EXPECT_GE(p.us[PwmChannels::kRoll], 1100);
    EXPECT_LE(p.us[PwmChannels::kRoll], 1900);
    for (int i = 0; i < 4; ++i) {
      EXPECT_GE(p.us[static_cast<std::size_t>(i)], 1000);
      EXPECT_LE(p.us[static_cast<std::size_t>(i)], 2000);
    }
    EXPECT_GE(p.us[PwmChannels::kThrottle], o.flight_min_throttle_us) << "flying never idles";
  }
  EXPECT_EQ(m.motors_off().us[PwmChannels::kThrottle], 1000);
}

TEST(PwmMapper, ReversedChannelsAndInverse) {
  PwmMapperOptions o;
  o.channels[PwmChannels::kPitch].reversed = true;
  const PwmMapper m(o);
  AttitudeThrustCommand c{10 * kDegToRad, 10 * kDegToRad, -30 * kDegToRad, 15.0};
  const auto p = m.map(c);
  EXPECT_GT(p.us[PwmChannels::kRoll], 1500);
  EXPECT_LT(p.us[PwmChannels::kPitch], 1500);
  const auto back = m.unmap(p);
  const double lsb = 45 * kDegToRad / 492;  // one microsecond of stick
  EXPECT_NEAR(back.roll_rad, c.roll_rad, lsb);
  EXPECT_NEAR(back.pitch_rad, c.pitch_rad, lsb);
  EXPECT_NEAR(back.yaw_rate_rad_s, c.yaw_rate_rad_s, 200 * kDegToRad / 492);
  EXPECT_NEAR(back.thrust_N, c.thrust_N, 28.0 / 1000);
}

TEST(PwmMapper, InvalidCalibrationIsAnInputError) {
  PwmMapperOptions o;
  o.channels[PwmChannels::kYaw].centre_us = 2100;
  EXPECT_THROW(PwmMapper{o}, kestrel::InputError);
}

TEST(SimulatedPwmOutput, HoldsTheLastPulsesAndCanDropTheLink) {
  SimulatedPwmOutput out;
  PwmChannels p;
  p.us = {1600, 1400, 1500, 1500};
  EXPECT_TRUE(out.write(p, 10).ok);
  out.set_link_up(false);
  PwmChannels q;
  const auto st = out.write(q, 20);
  EXPECT_FALSE(st.ok);
  EXPECT_EQ(out.latest(), p);
  EXPECT_EQ(out.latest_t_ns(), 10);
}

std::string read_text(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::string s;
  std::getline(in, s);
  return s;
}

TEST(SysfsPwmOutput, WritesPeriodDutyAndEnableUnderTheChip) {
  const auto chip = test::fresh_temp_dir("sysfs_pwm");
  for (int i = 0; i < 4; ++i)
    std::filesystem::create_directories(chip / ("pwm" + std::to_string(i)));
  const PwmMapper m;
  SysfsPwmOptions o;
  o.chip = chip;
  {
    SysfsPwmOutput out(o, m.motors_off());
    EXPECT_EQ(read_text(chip / "pwm0" / "period"), "20000000");
    EXPECT_EQ(read_text(chip / "pwm2" / "duty_cycle"), "1000000");
    EXPECT_EQ(read_text(chip / "pwm3" / "enable"), "1");
    PwmChannels p;
    p.us = {1612, 1388, 1455, 1500};
    ASSERT_TRUE(out.write(p, 0).ok);
    EXPECT_EQ(read_text(chip / "pwm0" / "duty_cycle"), "1612000");
    EXPECT_EQ(read_text(chip / "pwm1" / "duty_cycle"), "1388000");
    EXPECT_EQ(read_text(chip / "pwm2" / "duty_cycle"), "1455000");
    p.us[0] = 3000;
    EXPECT_FALSE(out.write(p, 0).ok);
  }
  EXPECT_EQ(read_text(chip / "pwm0" / "enable"), "0") << "disabled on close";
  std::filesystem::remove_all(chip);
}

TEST(SysfsPwmOutput, ExportsMissingChannelsAndNamesTheFailure) {
  const auto chip = test::fresh_temp_dir("sysfs_pwm_export");
  SysfsPwmOptions o;
  o.chip = chip;
  o.export_timeout_ms = 0;  // no kernel here to create pwm0
  try {
    SysfsPwmOutput out(o, PwmChannels{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("pwm0"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(chip / "export"), "0");
  o.chip = chip / "missing";
  EXPECT_THROW(SysfsPwmOutput(o, PwmChannels{}), std::runtime_error);
  std::filesystem::remove_all(chip);
}

TEST(Msp, FrameRoundTripsAndRejectsCorruption) {
  PwmChannels p;
  p.us = {1234, 1777, 1100, 1999};
  auto f = encode_msp_set_raw_rc(p);
  ASSERT_EQ(f.size(), 14U);
  EXPECT_EQ(f[4], 200);
  PwmChannels q;
  ASSERT_TRUE(decode_msp_set_raw_rc(f, q).ok);
  EXPECT_EQ(q, p);
  f[7] ^= 0x01;
  EXPECT_FALSE(decode_msp_set_raw_rc(f, q).ok);
}

TEST(SerialPwmOutput, SendsMspFramesOverAPseudoTerminal) {
  int master = -1, slave = -1;
  char name[256] = {};
  ASSERT_EQ(::openpty(&master, &slave, name, nullptr, nullptr), 0);
  {
    SerialPwmOptions o;
    o.device = name;
    SerialPwmOutput out(o);
    PwmChannels p;
    p.us = {1520, 1480, 1350, 1500};
    ASSERT_TRUE(out.write(p, 0).ok);
    std::vector<std::uint8_t> buf(14);
    std::size_t got = 0;
    for (int tries = 0; tries < 100 && got < buf.size(); ++tries) {
      const auto n = ::read(master, buf.data() + got, buf.size() - got);
      if (n > 0) got += static_cast<std::size_t>(n);
    }
    ASSERT_EQ(got, 14U);
    PwmChannels q;
    ASSERT_TRUE(decode_msp_set_raw_rc(buf, q).ok);
    EXPECT_EQ(q, p);
  }
  ::close(slave);
  ::close(master);
  SerialPwmOptions bad;
  bad.device = "/nonexistent/tty";
  EXPECT_THROW(SerialPwmOutput{bad}, std::runtime_error);
}

}  // namespace
}  // namespace kestrel::control
