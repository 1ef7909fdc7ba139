// PWM output backends: simulated, Linux sysfs PWM, serial MSP.
#include "kestrel/control/pwm_output.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <thread>

namespace kestrel::control {

namespace fs = std::filesystem;

namespace {

std::string errno_text() { return std::strerror(errno); }

// One whole write of `text` to a sysfs attribute (open, write, close), as the kernel expects.
void write_attribute(const fs::path& file, const std::string& text) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    throw std::runtime_error(file.string() + ": cannot open for writing: " + errno_text());
  const auto n = ::write(fd, text.data(), text.size());
  const std::string why = errno_text();
  ::close(fd);
  if (n != static_cast<ssize_t>(text.size()))
    throw std::runtime_error(file.string() + ": write failed: " + why);
}

speed_t baud_constant(int baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 921600:
      return B921600;
    default:
      throw std::runtime_error("serial output: unsupported baud rate " + std::to_string(baud));
  }
}

}  // namespace

OutputStatus SimulatedPwmOutput::write(const PwmChannels& pwm, TimeNs t_ns) {
  if (!link_up_) return {false, "sim: link down"};
  latest_ = pwm;
  latest_t_ns_ = t_ns;
  ++writes_;
  return {};
}

// --- sysfs ---

SysfsPwmOutput::SysfsPwmOutput(SysfsPwmOptions options, const PwmChannels& initial)
    : options_(std::move(options)) {
  if (options_.period_ns <= 2'200'000)
    throw std::runtime_error("sysfs PWM: period_ns must exceed 2.2 ms");
  if (!fs::is_directory(options_.chip))
    throw std::runtime_error(options_.chip.string() + ": no such PWM chip");
  for (std::size_t i = 0; i < 4; ++i) {
    const fs::path dir = channel_dir(i);
    if (!fs::is_directory(dir)) {
      write_attribute(options_.chip / "export", std::to_string(options_.channel_index[i]) + "\n");
      const auto deadline =
          std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.export_timeout_ms);
      while (!fs::is_directory(dir) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      if (!fs::is_directory(dir)) {
        throw std::runtime_error(dir.string() + ": did not appear after exporting channel " +
                                 std::to_string(options_.channel_index[i]));
      }
    }
    // The duty cycle may never exceed the period: set the period first, then the pulse.
    write_attribute(dir / "period", std::to_string(options_.period_ns) + "\n");
    write_attribute(dir / "duty_cycle",
                    std::to_string(static_cast<std::int64_t>(initial.us[i]) * 1000) + "\n");
    write_attribute(dir / "enable", "1\n");
    last_us_[i] = initial.us[i];
  }
}

SysfsPwmOutput::~SysfsPwmOutput() {
  for (std::size_t i = 0; i < 4; ++i) {
    if (options_.disable_on_close) {
      try {
        write_attribute(channel_dir(i) / "enable", "0\n");
      } catch (const std::exception&) {
        // Nothing more can be done in a destructor; the pulses stop with the process anyway.
      }
    }
  }
}

fs::path SysfsPwmOutput::channel_dir(std::size_t i) const {
  return options_.chip / ("pwm" + std::to_string(options_.channel_index[i]));
}

OutputStatus SysfsPwmOutput::write(const PwmChannels& pwm, TimeNs /*t_ns*/) {
  for (std::size_t i = 0; i < 4; ++i) {
    if (pwm.us[i] == last_us_[i]) continue;
    if (pwm.us[i] < 500 || pwm.us[i] > 2500) {
      return {false,
              channel_dir(i).string() + ": pulse of " + std::to_string(pwm.us[i]) + " us refused"};
    }
    // One open-write-close per change, as sysfs attributes expect (a few us; 4 x 100 Hz).
    try {
      write_attribute(channel_dir(i) / "duty_cycle",
                      std::to_string(static_cast<std::int64_t>(pwm.us[i]) * 1000) + "\n");
    } catch (const std::exception& e) {
      return {false, e.what()};
    }
    last_us_[i] = pwm.us[i];
  }
  return {};
}

// --- MSP ---

std::vector<std::uint8_t> encode_msp_set_raw_rc(const PwmChannels& pwm) {
  std::vector<std::uint8_t> f{'$', 'M', '<', 8, kMspSetRawRc};
  for (int us : pwm.us) {
    const auto v = static_cast<std::uint16_t>(std::clamp(us, 0, 65535));
    f.push_back(static_cast<std::uint8_t>(v & 0xFF));
    f.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  std::uint8_t checksum = 0;
  for (std::size_t i = 3; i < f.size(); ++i) checksum ^= f[i];
  f.push_back(checksum);
  return f;
}

OutputStatus decode_msp_set_raw_rc(const std::vector<std::uint8_t>& f, PwmChannels& pwm) {
  if (f.size() != 14)
    return {false, "MSP frame: expected 14 bytes, got " + std::to_string(f.size())};
  if (f[0] != '$' || f[1] != 'M' || f[2] != '<') return {false, "MSP frame: bad header"};
  if (f[3] != 8 || f[4] != kMspSetRawRc)
    return {false, "MSP frame: not MSP_SET_RAW_RC with 4 channels"};
  std::uint8_t checksum = 0;
  for (std::size_t i = 3; i < 13; ++i) checksum ^= f[i];
  if (checksum != f[13]) return {false, "MSP frame: checksum mismatch"};
  for (std::size_t i = 0; i < 4; ++i) pwm.us[i] = f[5 + 2 * i] | (f[6 + 2 * i] << 8);
  return {};
}

SerialPwmOutput::SerialPwmOutput(SerialPwmOptions options) : options_(std::move(options)) {
  const speed_t speed = baud_constant(options_.baud);
  fd_ = ::open(options_.device.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (fd_ < 0)
    throw std::runtime_error(options_.device.string() + ": cannot open: " + errno_text());
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    const std::string why = errno_text();
    ::close(fd_);
    throw std::runtime_error(options_.device.string() + ": not a serial device: " + why);
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~(CSTOPB | PARENB);
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const std::string why = errno_text();
    ::close(fd_);
    throw std::runtime_error(options_.device.string() + ": cannot configure: " + why);
  }
}

SerialPwmOutput::~SerialPwmOutput() {
  if (fd_ >= 0) ::close(fd_);
}

OutputStatus SerialPwmOutput::write(const PwmChannels& pwm, TimeNs /*t_ns*/) {
  const auto frame = encode_msp_set_raw_rc(pwm);
  std::size_t done = 0;
  while (done < frame.size()) {
    const auto n = ::write(fd_, frame.data() + done, frame.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return {false, options_.device.string() + ": write failed: " + errno_text()};
    }
    done += static_cast<std::size_t>(n);
  }
  return {};
}

}  // namespace kestrel::control
