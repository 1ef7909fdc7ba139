// Where the four RC pulses go: an output backend interface with a simulated backend (feeds the
// flight-controller model), a Linux sysfs PWM backend (/sys/class/pwm/pwmchipN/pwmM: the
// Jetson's own PWM pins wired to the flight controller's receiver inputs, as in thesis 4.3)
// and a serial backend speaking MSP (MultiWii Serial Protocol, MSP_SET_RAW_RC) to a flight
// controller or a PWM-generating bridge board.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "kestrel/control/types.hpp"

namespace kestrel::control {

/// The result of one write, with its health.
struct OutputStatus {
  bool ok = true;
  std::string error;  ///< what failed, naming the file or device
};

class PwmOutput {
 public:
  virtual ~PwmOutput() = default;
  /// Sends the four pulse widths; t_ns is the command's time (for logs and simulated links).
  virtual OutputStatus write(const PwmChannels& pwm, TimeNs t_ns) = 0;
  [[nodiscard]] virtual std::string name() const = 0;
};

/// The simulated link: keeps the last pulses like a real PWM generator does (it goes on
/// emitting them whatever the software does), optionally dropping writes to model a dead link.
class SimulatedPwmOutput final : public PwmOutput {
 public:
  explicit SimulatedPwmOutput(PwmChannels initial = {}) : latest_(initial) {}
  OutputStatus write(const PwmChannels& pwm, TimeNs t_ns) override;
  [[nodiscard]] std::string name() const override { return "sim"; }
  /// What the flight controller sees now.
  [[nodiscard]] const PwmChannels& latest() const { return latest_; }
  [[nodiscard]] TimeNs latest_t_ns() const { return latest_t_ns_; }
  [[nodiscard]] std::int64_t write_count() const { return writes_; }
  void set_link_up(bool up) { link_up_ = up; }

 private:
  PwmChannels latest_;
  TimeNs latest_t_ns_ = 0;
  std::int64_t writes_ = 0;
  bool link_up_ = true;
};

struct SysfsPwmOptions {
  std::filesystem::path chip = "/sys/class/pwm/pwmchip0";
  std::array<int, 4> channel_index{0, 1, 2, 3};  ///< pwmN of roll, pitch, throttle, yaw
  std::int64_t period_ns = 20'000'000;           ///< 50 Hz servo frame
  int export_timeout_ms = 500;   ///< wait for the kernel to create pwmN after exporting it
  bool disable_on_close = true;  ///< stop the pulses on exit: the FC's signal-loss failsafe
};

/// Linux sysfs PWM. Opening exports the channels that are not yet exported, writes period,
/// the first duty cycle and enable; writes then update duty_cycle (ns) of changed channels.
/// Works on any directory laid out like a pwmchip (tests use a temporary one).
class SysfsPwmOutput final : public PwmOutput {
 public:
  /// Throws std::runtime_error naming the path that could not be set up.
  SysfsPwmOutput(SysfsPwmOptions options, const PwmChannels& initial);
  ~SysfsPwmOutput() override;
  SysfsPwmOutput(const SysfsPwmOutput&) = delete;
  SysfsPwmOutput& operator=(const SysfsPwmOutput&) = delete;
  OutputStatus write(const PwmChannels& pwm, TimeNs t_ns) override;
  [[nodiscard]] std::string name() const override { return "sysfs:" + options_.chip.string(); }

 private:
  [[nodiscard]] std::filesystem::path channel_dir(std::size_t i) const;
  SysfsPwmOptions options_;
  std::array<int, 4> last_us_{-1, -1, -1, -1};
};

/// MSP v1 frame "$M<" size cmd payload checksum (XOR of size, cmd and payload) carrying
/// MSP_SET_RAW_RC (200): the channels as little-endian uint16 in AETR order.
inline constexpr std::uint8_t kMspSetRawRc = 200;
std::vector<std::uint8_t> encode_msp_set_raw_rc(const PwmChannels& pwm);
/// Decodes one such frame; the OutputStatus says why a frame is rejected.
OutputStatus decode_msp_set_raw_rc(const std::vector<std::uint8_t>& frame, PwmChannels& pwm);

struct SerialPwmOptions {
  std::filesystem::path device = "/dev/ttyTHS1";  ///< the Jetson TK1's UART
  int baud = 115200;
};

/// A serial link (termios, raw 8N1) sending one MSP_SET_RAW_RC frame per write.
class SerialPwmOutput final : public PwmOutput {
 public:
  /// Throws std::runtime_error naming the device that could not be opened or configured.
  explicit SerialPwmOutput(SerialPwmOptions options);
  ~SerialPwmOutput() override;
  SerialPwmOutput(const SerialPwmOutput&) = delete;
  SerialPwmOutput& operator=(const SerialPwmOutput&) = delete;
  OutputStatus write(const PwmChannels& pwm, TimeNs t_ns) override;
  [[nodiscard]] std::string name() const override { return "serial:" + options_.device.string(); }

 private:
  SerialPwmOptions options_;
  int fd_ = -1;
};

}  // namespace kestrel::control
