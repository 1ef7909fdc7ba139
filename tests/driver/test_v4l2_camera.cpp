// V4l2Camera: the errors a user sees for a missing or wrong device (real system calls), and,
// against a stand-in device, format negotiation, streaming with time stamps, and the faults a
// camera shows at run time: unplugging, stalls, spurious wake-ups, corrupted frames.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <string>

#include "fake_v4l2_device.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::driver::CameraOptions;
using kestrel::driver::CapturedFrame;
using kestrel::driver::DeviceError;
using kestrel::driver::TimestampClock;
using kestrel::driver::V4l2Camera;
using kestrel::test::fake_event;
using kestrel::test::fake_frame;
using kestrel::test::FakeEvent;
using kestrel::test::FakeV4l2Device;
using Status = CapturedFrame::Status;

std::string error_of(const std::string& device) {
  try {
    V4l2Camera camera(device);
  } catch (const DeviceError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(V4l2Camera, AMissingDeviceGivesAClearError) {
  const auto dir = kestrel::test::fresh_temp_dir("v4l2_missing");
  const std::string device = (dir / "video7").string();
  try {
    V4l2Camera camera(device);
    FAIL() << "opened a device that does not exist";
  } catch (const DeviceError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(device + ": no such video device", 0), 0U) << what;
    EXPECT_NE(what.find("kestrel capture --list"), std::string::npos) << what;
    EXPECT_EQ(e.error_number(), ENOENT);
  }
  fs::remove_all(dir);
}

TEST(V4l2Camera, AFileThatIsNoVideoDeviceIsNamedAsSuch) {
  EXPECT_EQ(error_of("/dev/null").rfind("/dev/null: not a V4L2 video device", 0), 0U)
      << error_of("/dev/null");
  const auto dir = kestrel::test::fresh_temp_dir("v4l2_plain_file");
  std::ofstream(dir / "video0") << "not a camera";
  const std::string what = error_of((dir / "video0").string());
  EXPECT_NE(what.find("not a V4L2 video device"), std::string::npos) << what;
  fs::remove_all(dir);
}

TEST(V4l2Camera, ListsOnlyVideoNodesInNumericOrder) {
  const auto dir = kestrel::test::fresh_temp_dir("v4l2_list");
  for (const char* name : {"video10", "video2", "video", "videoX", "vbi0", "video0a", "media0"}) {
    std::ofstream(dir / name) << "";
  }
  const auto found = kestrel::driver::list_video_devices(dir);
  ASSERT_EQ(found.size(), 2U);
  EXPECT_EQ(found[0], dir / "video2");
  EXPECT_EQ(found[1], dir / "video10");
  EXPECT_TRUE(kestrel::driver::list_video_devices(dir / "absent").empty());
  fs::remove_all(dir);
}

TEST(V4l2Camera, FourccCodesMatchTheKernelsAndRoundTrip) {
  EXPECT_EQ(kestrel::driver::fourcc_from_string("YUYV"), V4L2_PIX_FMT_YUYV);
  EXPECT_EQ(kestrel::driver::fourcc_from_string("Y8I"), V4L2_PIX_FMT_Y8I);
  EXPECT_EQ(kestrel::driver::fourcc_to_string(V4L2_PIX_FMT_MJPEG), "MJPG");
  EXPECT_EQ(kestrel::driver::fourcc_to_string(V4L2_PIX_FMT_Y8I), "Y8I");
  EXPECT_FALSE(kestrel::driver::fourcc_from_string("").has_value());
  EXPECT_FALSE(kestrel::driver::fourcc_from_string("YUYV2").has_value());
  EXPECT_EQ(kestrel::driver::timeval_to_ns(1'700'000'000, 123'456), 1'700'000'000'123'456'000);
}

class FakeCamera : public ::testing::Test {
 protected:
  std::shared_ptr<FakeV4l2Device> device_ = std::make_shared<FakeV4l2Device>();

  std::unique_ptr<V4l2Camera> open_streaming(const CameraOptions& options = {}) {
    auto camera = std::make_unique<V4l2Camera>("/dev/fake0", device_);
    camera->configure(options);
    camera->start();
    return camera;
  }
  static std::vector<std::uint8_t> bytes(std::size_t n, std::uint8_t first) {
    std::vector<std::uint8_t> b(n);
    for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(first + i);
    return b;
  }
  static constexpr std::size_t kFrameBytes = 752 * 480 * 2;
};

TEST_F(FakeCamera, DescribesTheDeviceAndItsFormats) {
  V4l2Camera camera("/dev/fake0", device_);
  EXPECT_EQ(camera.info().driver, "fake");
  EXPECT_TRUE(camera.info().can_capture);
  EXPECT_TRUE(camera.info().can_stream);
  const auto formats = camera.formats();
  ASSERT_EQ(formats.size(), 2U);
  EXPECT_EQ(formats[0].describe(), "YUYV (fake format): 752x480 @ 30, 60 Hz; 376x240 @ 30, 60 Hz");
  EXPECT_EQ(formats[1].fourcc, V4L2_PIX_FMT_MJPEG);
}

TEST_F(FakeCamera, NegotiatesTheFormatAndRate) {
  V4l2Camera camera("/dev/fake0", device_);
  device_->padding_per_line = 32;
  CameraOptions o;
  o.rate_hz = 60.0;
  const auto format = camera.configure(o);
  EXPECT_EQ(format.fourcc, V4L2_PIX_FMT_YUYV);
  EXPECT_EQ(format.width, 752);
  EXPECT_EQ(format.bytes_per_line, 752U * 2U + 32U);
  EXPECT_DOUBLE_EQ(format.rate_hz, 60.0);
  EXPECT_TRUE(format.notes.empty());
}

TEST_F(FakeCamera, AWrongPixelFormatIsAnErrorListingWhatTheDeviceOffers) {
  device_->forced_fourcc = V4L2_PIX_FMT_MJPEG;
  V4l2Camera camera("/dev/fake0", device_);
  try {
    camera.configure({});
    FAIL() << "accepted MJPG for YUYV";
  } catch (const DeviceError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/dev/fake0: wrong pixel format: asked for YUYV, the device gives MJPG"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("YUYV (fake format): 752x480"), std::string::npos) << what;
  }
}

TEST_F(FakeCamera, AnAdjustedSizeIsAnError) {
  device_->forced_width = 640;
  V4l2Camera camera("/dev/fake0", device_);
  try {
    camera.configure({});
    FAIL() << "accepted 640x480 for 752x480";
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("wrong frame size: asked for 752x480, the device gives "
                                         "640x480"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(FakeCamera, AnOutputOnlyDeviceIsRefused) {
  device_->caps = V4L2_CAP_VIDEO_OUTPUT | V4L2_CAP_STREAMING;
  V4l2Camera camera("/dev/fake0", device_);
  EXPECT_THROW(camera.configure({}), DeviceError);
  EXPECT_TRUE(camera.formats().empty());
}

TEST_F(FakeCamera, OpenErrorsSayWhatToDo) {
  device_->open_errno = EACCES;
  try {
    V4l2Camera camera("/dev/fake0", device_);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("permission denied"), std::string::npos);
  }
  device_->open_errno = EBUSY;
  try {
    V4l2Camera camera("/dev/fake0", device_);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("busy"), std::string::npos);
  }
}

TEST_F(FakeCamera, StreamsFramesWithTheirHardwareTimeStamps) {
  device_->script.push_back(fake_frame(bytes(kFrameBytes, 1), 5'000'000'033'000, 7));
  device_->script.push_back(fake_frame(bytes(kFrameBytes, 2), 5'000'000'066'000, 8));
  auto camera = open_streaming();
  EXPECT_EQ(device_->maps, 4);
  EXPECT_EQ(device_->queued(), 4U);

  const CapturedFrame a = camera->next(1000);
  ASSERT_EQ(a.status, Status::kFrame) << a.message;
  EXPECT_EQ(a.t_ns, 5'000'000'033'000'000);
  EXPECT_EQ(a.clock, TimestampClock::kMonotonic);
  EXPECT_TRUE(a.start_of_exposure);
  EXPECT_EQ(a.sequence, 7U);
  ASSERT_EQ(a.data.size(), kFrameBytes);
  EXPECT_EQ(a.data[0], 1);
  EXPECT_EQ(a.data[10], 11);
  EXPECT_EQ(device_->queued(), 3U);  // lent to us

  const CapturedFrame b = camera->next(1000);
  ASSERT_EQ(b.status, Status::kFrame) << b.message;
  EXPECT_EQ(b.t_ns, 5'000'000'066'000'000);
  EXPECT_EQ(b.data[0], 2);
  EXPECT_EQ(device_->queued(), 3U);  // the first went back before the second came
  EXPECT_EQ(camera->frames_lost(), 0U);
  EXPECT_EQ(device_->dqbuf_with_empty_queue, 0);

  camera->stop();
  EXPECT_FALSE(device_->streaming);
  EXPECT_EQ(device_->unmaps, 4);
}

TEST_F(FakeCamera, SequenceGapsCountAsLostFrames) {
  for (const std::uint32_t seq : {10U, 11U, 14U, 15U, 20U}) {
    device_->script.push_back(fake_frame(bytes(64, 0), 1'000 + seq * 33'000, seq));
  }
  auto camera = open_streaming();
  for (int i = 0; i < 5; ++i) ASSERT_EQ(camera->next(1000).status, Status::kFrame);
  EXPECT_EQ(camera->frames_lost(), 6U);  // 12, 13, 16..19
}

TEST_F(FakeCamera, AStalledStreamTimesOutInTime) {
  auto camera = open_streaming();
  const auto start = std::chrono::steady_clock::now();
  const CapturedFrame f = camera->next(80);
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(f.status, Status::kTimeout);
  EXPECT_NE(f.message.find("no frame within 80 ms"), std::string::npos) << f.message;
  EXPECT_GE(waited_s, 0.079);
  EXPECT_LT(waited_s, 1.0);
}

TEST_F(FakeCamera, SpuriousWakeUpsAreWaitedThrough) {
  device_->script.push_back(fake_event(FakeEvent::Kind::kSpuriousWakeup));
  device_->script.push_back(fake_event(FakeEvent::Kind::kSpuriousWakeup));
  device_->script.push_back(fake_frame(bytes(64, 5), 2'000, 1));
  auto camera = open_streaming();
  const CapturedFrame f = camera->next(1000);
  ASSERT_EQ(f.status, Status::kFrame) << f.message;
  EXPECT_EQ(f.data[0], 5);
}

TEST_F(FakeCamera, EndlessSpuriousWakeUpsStillTimeOut) {
  device_->wakes_forever = true;
  auto camera = open_streaming();
  const auto start = std::chrono::steady_clock::now();
  const CapturedFrame f = camera->next(50);
  EXPECT_EQ(f.status, Status::kTimeout);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

TEST_F(FakeCamera, UnpluggingMidStreamIsReportedAndCleanedUp) {
  device_->script.push_back(fake_frame(bytes(64, 0), 1'000, 1));
  device_->script.push_back(fake_event(FakeEvent::Kind::kDqbufError, ENODEV));
  auto camera = open_streaming();
  ASSERT_EQ(camera->next(1000).status, Status::kFrame);
  const CapturedFrame f = camera->next(1000);
  EXPECT_EQ(f.status, Status::kDisconnected);
  EXPECT_NE(f.message.find("/dev/fake0: device disconnected"), std::string::npos) << f.message;
  // Further waits say so at once instead of waiting out their timeout.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(camera->next(5000).status, Status::kDisconnected);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.5);
  EXPECT_NO_THROW(camera->stop());
  EXPECT_EQ(device_->unmaps, device_->maps);
  camera.reset();
  EXPECT_EQ(device_->closes, 1);
}

TEST_F(FakeCamera, PollErrorsMeanTheDeviceIsGone) {
  device_->script.push_back(fake_event(FakeEvent::Kind::kPollRevents, 0, POLLERR));
  auto camera = open_streaming();
  const CapturedFrame f = camera->next(1000);
  EXPECT_EQ(f.status, Status::kDisconnected);
  EXPECT_NE(f.message.find("POLLERR"), std::string::npos) << f.message;
}

TEST_F(FakeCamera, CorruptedFramesAreFlaggedAndTheStreamGoesOn) {
  FakeEvent bad = fake_frame(bytes(64, 0), 1'000, 1);
  bad.flags |= V4L2_BUF_FLAG_ERROR;
  device_->script.push_back(bad);
  device_->script.push_back(fake_event(FakeEvent::Kind::kDqbufError, EIO));
  device_->script.push_back(fake_frame(bytes(64, 0), 2'000, 2));
  auto camera = open_streaming();
  EXPECT_EQ(camera->next(1000).status, Status::kCorrupted);
  EXPECT_EQ(camera->next(1000).status, Status::kCorrupted);
  EXPECT_EQ(camera->next(1000).status, Status::kFrame);
}

TEST_F(FakeCamera, AFrameWithoutTimeStampGetsTheHostClock) {
  FakeEvent e = fake_frame(bytes(64, 0), 0, 1);
  e.flags = V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN;
  device_->script.push_back(e);
  auto camera = open_streaming();
  const CapturedFrame f = camera->next(1000);
  ASSERT_EQ(f.status, Status::kFrame);
  EXPECT_EQ(f.clock, TimestampClock::kHost);
  EXPECT_GT(f.t_ns, 0);
}

TEST_F(FakeCamera, MisuseIsALogicError) {
  V4l2Camera camera("/dev/fake0", device_);
  EXPECT_THROW(camera.start(), std::logic_error);
  EXPECT_THROW((void)camera.next(10), std::logic_error);
}

}  // namespace
