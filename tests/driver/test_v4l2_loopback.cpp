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
#include "v4l2_loopback_device.hpp"

namespace {

using kestrel::driver::CapturedFrame;
using kestrel::driver::StereoFrameDecoder;
using kestrel::driver::StereoMosaic;
using kestrel::driver::V4l2Camera;
using kestrel::test::find_loopback;
using kestrel::test::LoopbackSearch;
using kestrel::test::LoopbackWriter;

constexpr int kLoopbackWidth = 752;
constexpr int kLoopbackHeight = 480;

TEST(V4l2Loopback, CapturesAndDecodesFramesWrittenToALoopbackDevice) {
  const LoopbackSearch search = find_loopback();
  if (!search.device) GTEST_SKIP() << "no v4l2loopback device: " << search.why_not;

  StereoFrameDecoder decoder;  // 752x480, left in byte 0, GRBG
  std::vector<StereoMosaic> sent;
  std::vector<std::vector<std::uint8_t>> frames;
  for (std::uint64_t k = 0; k < 4; ++k) {
    StereoMosaic m{kestrel::test::random_mosaic(kLoopbackWidth, kLoopbackHeight, 10 + 2 * k),
                   kestrel::test::random_mosaic(kLoopbackWidth, kLoopbackHeight, 11 + 2 * k)};
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
