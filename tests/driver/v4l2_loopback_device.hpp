// A v4l2loopback device for tests against the real kernel path: finding a writable one (or
// saying why there is none, for the skip message) and feeding packed frames into its output
// side from a thread. Used by tests/driver and tests/pipeline.
#pragma once

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "kestrel/driver/v4l2_camera.hpp"

namespace kestrel::test {

/// The first /dev/video* node served by the v4l2loopback driver that we may write, or why none.
struct LoopbackSearch {
  std::optional<std::string> device;
  std::string why_not;
};

inline LoopbackSearch find_loopback() {
  const auto nodes = driver::list_video_devices();
  std::ostringstream seen;
  for (const auto& node : nodes) {
    std::string name = "?";  // the node's driver, or why it could not be opened
    try {
      name = driver::V4l2Camera(node.string()).info().driver;
    } catch (const std::exception& e) {
      name = e.what();
    }
    seen << " " << node.string() << " (" << name << ")";
    if (name.find("loopback") == std::string::npos) continue;
    if (::access(node.c_str(), W_OK) != 0) {
      seen << " [not writable: " << std::strerror(errno) << "]";
      continue;
    }
    return {node.string(), ""};
  }
  std::ostringstream why;
  if (nodes.empty()) {
    why << "/dev has no video* nodes";
  } else {
    why << "no writable v4l2loopback node among" << seen.str();
  }
  why << (std::filesystem::exists("/sys/module/v4l2loopback")
              ? "; the v4l2loopback module is loaded"
              : "; the v4l2loopback module is not loaded");
  const bool modprobe =
      std::filesystem::exists("/sbin/modprobe") || std::filesystem::exists("/usr/sbin/modprobe") ||
      std::filesystem::exists("/bin/modprobe") || std::filesystem::exists("/usr/bin/modprobe");
  if (!modprobe) why << " and this machine has no modprobe (kernel modules cannot be loaded here)";
  why << ". To run this test: sudo modprobe v4l2loopback exclusive_caps=0 (package "
         "v4l2loopback-dkms)";
  return {std::nullopt, why.str()};
}

/// Feeds `frames` (packed YUYV, width x height, unpadded) round-robin into the loopback's
/// output side until destroyed.
class LoopbackWriter {
 public:
  LoopbackWriter(const std::string& device, std::vector<std::vector<std::uint8_t>> frames,
                 int width = 752, int height = 480)
      : frames_(std::move(frames)) {
    const auto w = static_cast<std::uint32_t>(width);
    const auto h = static_cast<std::uint32_t>(height);
    fd_ = ::open(device.c_str(), O_RDWR | O_CLOEXEC);  // NOLINT(*-vararg)
    if (fd_ == -1) throw std::runtime_error(device + ": " + std::strerror(errno));
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    fmt.fmt.pix.width = w;
    fmt.fmt.pix.height = h;
    fmt.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    fmt.fmt.pix.bytesperline = 2 * w;
    fmt.fmt.pix.sizeimage = 2 * w * h;
    if (::ioctl(fd_, VIDIOC_S_FMT, &fmt) == -1) {  // NOLINT(*-vararg)
      const std::string error = std::strerror(errno);
      ::close(fd_);
      throw std::runtime_error(device + ": output VIDIOC_S_FMT: " + error);
    }
    // The first frame before any reader opens: with exclusive_caps the capture side appears
    // only once a writer has produced something.
    write_one(0);
    thread_ = std::thread([this] {
      for (std::size_t k = 1; !stop_.load(); ++k) {
        write_one(k % frames_.size());
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  ~LoopbackWriter() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
  }
  LoopbackWriter(const LoopbackWriter&) = delete;
  LoopbackWriter& operator=(const LoopbackWriter&) = delete;

 private:
  void write_one(std::size_t k) {
    const auto& f = frames_[k];
    if (::write(fd_, f.data(), f.size()) != static_cast<ssize_t>(f.size())) write_errors_++;
  }
  int fd_ = -1;
  std::vector<std::vector<std::uint8_t>> frames_;
  std::atomic<bool> stop_{false};
  std::atomic<int> write_errors_{0};
  std::thread thread_;
};

}  // namespace kestrel::test
