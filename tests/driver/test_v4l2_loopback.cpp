// V4l2Camera against a real kernel driver: a v4l2loopback device fed with packed stereo frames
// by a writer thread. Runs where such a device exists and is writable
// (`sudo modprobe v4l2loopback exclusive_caps=0`); elsewhere it skips and says why.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "stereo_test_frames.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::driver::CapturedFrame;
using kestrel::driver::StereoFrameDecoder;
using kestrel::driver::StereoMosaic;
using kestrel::driver::V4l2Camera;

constexpr int kWidth = 752;
constexpr int kHeight = 480;

/// The first /dev/video* node served by the v4l2loopback driver that we may write, or why none.
struct LoopbackSearch {
  std::optional<std::string> device;
  std::string why_not;
};

LoopbackSearch find_loopback() {
  const auto nodes = kestrel::driver::list_video_devices();
  std::ostringstream seen;
  for (const auto& node : nodes) {
    std::string driver = "?";
    try {
      driver = V4l2Camera(node.string()).info().driver;
    } catch (const std::exception& e) {
      driver = e.what();
    }
    seen << " " << node.string() << " (" << driver << ")";
    if (driver.find("loopback") == std::string::npos) continue;
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
  why << (fs::exists("/sys/module/v4l2loopback") ? "; the v4l2loopback module is loaded"
                                                 : "; the v4l2loopback module is not loaded");
  const bool modprobe = fs::exists("/sbin/modprobe") || fs::exists("/usr/sbin/modprobe") ||
                        fs::exists("/bin/modprobe") || fs::exists("/usr/bin/modprobe");
  if (!modprobe) why << " and this machine has no modprobe (kernel modules cannot be loaded here)";
  why << ". To run this test: sudo modprobe v4l2loopback exclusive_caps=0 (package "
         "v4l2loopback-dkms)";
  return {std::nullopt, why.str()};
}

/// Feeds `frames` round-robin into the loopback's output side until stopped.
class LoopbackWriter {
 public:
  LoopbackWriter(const std::string& device, std::vector<std::vector<std::uint8_t>> frames)
      : frames_(std::move(frames)) {
    fd_ = ::open(device.c_str(), O_RDWR | O_CLOEXEC);  // NOLINT(*-vararg)
    if (fd_ == -1) throw std::runtime_error(device + ": " + std::strerror(errno));
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    fmt.fmt.pix.width = kWidth;
    fmt.fmt.pix.height = kHeight;
    fmt.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    fmt.fmt.pix.bytesperline = 2 * kWidth;
    fmt.fmt.pix.sizeimage = 2 * kWidth * kHeight;
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

TEST(V4l2Loopback, CapturesAndDecodesFramesWrittenToALoopbackDevice) {
  const LoopbackSearch search = find_loopback();
  if (!search.device) GTEST_SKIP() << "no v4l2loopback device: " << search.why_not;

  StereoFrameDecoder decoder;  // 752x480, left in byte 0, GRBG
  std::vector<StereoMosaic> sent;
  std::vector<std::vector<std::uint8_t>> frames;
  for (std::uint64_t k = 0; k < 4; ++k) {
    StereoMosaic m{kestrel::test::random_mosaic(kWidth, kHeight, 10 + 2 * k),
                   kestrel::test::random_mosaic(kWidth, kHeight, 11 + 2 * k)};
    frames.push_back(kestrel::test::pack_by_hand(m.left, m.right, 0));
    sent.push_back(m);
  }
  LoopbackWriter writer(*search.device, frames);

  V4l2Camera camera(*search.device);
  const auto format = camera.configure({});
  EXPECT_EQ(format.fourcc, V4L2_PIX_FMT_YUYV);
  camera.start();
  StereoMosaic out;
  std::size_t matched = 0;
  std::optional<kestrel::TimeNs> last_t_ns;
  for (int i = 0; i < 10; ++i) {
    const CapturedFrame f = camera.next(2000);
    ASSERT_EQ(f.status, CapturedFrame::Status::kFrame) << f.message;
    const auto health = decoder.split(f.data, format.bytes_per_line, out);
    ASSERT_TRUE(health.ok()) << health.describe();
    for (const StereoMosaic& m : sent) {
      if (kestrel::test::identical(out.left, m.left) &&
          kestrel::test::identical(out.right, m.right)) {
        ++matched;
        break;
      }
    }
    if (last_t_ns) {
      EXPECT_GT(f.t_ns, *last_t_ns);
    }
    last_t_ns = f.t_ns;
  }
  EXPECT_EQ(matched, 10U) << "every captured frame must be one of the frames written";
  camera.stop();
}

}  // namespace
