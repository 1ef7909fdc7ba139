// A capture run against the stand-in device, into the recorder: frames arrive exactly, faults
// (truncated frames, unplugging, stalls, out-of-order stamps) are logged and end or skip as
// documented, and the folder reads back as an EuRoC sequence.
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <sstream>
#include <string>

#include "fake_v4l2_device.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/driver/stereo_capture.hpp"
#include "kestrel/driver/stereo_recorder.hpp"
#include "kestrel/io/euroc.hpp"
#include "stereo_test_frames.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::TimeNs;
using kestrel::driver::CameraOptions;
using kestrel::driver::CaptureLimits;
using kestrel::driver::CaptureReport;
using kestrel::driver::CaptureStop;
using kestrel::driver::RecorderOptions;
using kestrel::driver::StereoDecoderOptions;
using kestrel::driver::StereoFrameDecoder;
using kestrel::driver::StereoMosaic;
using kestrel::driver::StereoRecorder;
using kestrel::driver::V4l2Camera;
using kestrel::driver::ViewKind;
using kestrel::test::fake_event;
using kestrel::test::fake_frame;
using kestrel::test::FakeEvent;
using kestrel::test::identical;

constexpr int kWidth = 64;
constexpr int kHeight = 48;

struct Received {
  TimeNs t_ns;
  cv::Mat left;
  cv::Mat right;
};

class StereoCapture : public ::testing::Test {
 protected:
  void SetUp() override {
    device_->formats = {{V4L2_PIX_FMT_YUYV, {{kWidth, kHeight}}}};
    device_->padding_per_line = 16;  // rows with padding, as some drivers deliver them
    options_.width = kWidth;
    options_.height = kHeight;
  }

  /// Frame k: random mosaics, packed by hand with the stride the device reports.
  void add_frame(int k, std::int64_t t_us, std::uint32_t sequence, std::size_t cut = 0) {
    cv::Mat left =
        kestrel::test::random_mosaic(kWidth, kHeight, 100 + 2 * static_cast<std::uint64_t>(k));
    cv::Mat right =
        kestrel::test::random_mosaic(kWidth, kHeight, 101 + 2 * static_cast<std::uint64_t>(k));
    auto bytes = kestrel::test::pack_by_hand(left, right, options_.left_byte, 2 * kWidth + 16);
    if (cut > 0) bytes.resize(bytes.size() - cut);
    device_->script.push_back(fake_frame(bytes, t_us, sequence));
    sent_.push_back({t_us * 1000, left, right});
  }

  CaptureReport run(const CaptureLimits& limits, const std::atomic<bool>* interrupt = nullptr) {
    V4l2Camera camera("/dev/fake0", device_);
    CameraOptions c;
    c.width = kWidth;
    c.height = kHeight;
    const auto format = camera.configure(c);
    kestrel::driver::CaptureHooks hooks;
    hooks.log = &log_;
    hooks.interrupt = interrupt;
    const StereoFrameDecoder decoder(options_);
    const auto report = kestrel::driver::capture_stereo(
        camera, format, decoder, limits,
        [&](TimeNs t_ns, const StereoMosaic& m, std::span<const std::uint8_t> packed,
            std::size_t bytes_per_line) {
          received_.push_back({t_ns, m.left.clone(), m.right.clone()});
          if (recorder_) recorder_->write(t_ns, m, packed, bytes_per_line);
        },
        hooks);
    EXPECT_FALSE(camera.streaming());
    return report;
  }

  std::shared_ptr<kestrel::test::FakeV4l2Device> device_ =
      std::make_shared<kestrel::test::FakeV4l2Device>();
  StereoDecoderOptions options_;
  std::vector<Received> sent_;
  std::vector<Received> received_;
  std::ostringstream log_;
  std::unique_ptr<StereoRecorder> recorder_;
};

TEST_F(StereoCapture, DeliversEveryFrameExactlyUntilTheCount) {
  for (int k = 0; k < 6; ++k) add_frame(k, 1'000'000 + 33'333 * k, static_cast<std::uint32_t>(k));
  CaptureLimits limits;
  limits.frames = 4;
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.stop, CaptureStop::kFrames);
  EXPECT_TRUE(r.ended_as_asked());
  ASSERT_EQ(r.frames, 4U);
  ASSERT_EQ(received_.size(), 4U);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(received_[k].t_ns, sent_[k].t_ns);
    EXPECT_TRUE(identical(received_[k].left, sent_[k].left)) << k;
    EXPECT_TRUE(identical(received_[k].right, sent_[k].right)) << k;
  }
  EXPECT_EQ(r.first_t_ns, sent_[0].t_ns);
  EXPECT_EQ(r.last_t_ns, sent_[3].t_ns);
  EXPECT_EQ(device_->unmaps, device_->maps);
}

TEST_F(StereoCapture, TruncatedFramesAreLoggedAndSkipped) {
  add_frame(0, 1'000, 0);
  add_frame(1, 2'000, 1, 500);
  add_frame(2, 3'000, 2);
  CaptureLimits limits;
  limits.frames = 2;
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.frames, 2U);
  EXPECT_EQ(r.truncated, 1U);
  ASSERT_EQ(received_.size(), 2U);
  EXPECT_TRUE(identical(received_[1].left, sent_[2].left));
  EXPECT_NE(log_.str().find("frame 1 dropped: truncated"), std::string::npos) << log_.str();
}

TEST_F(StereoCapture, UnpluggingEndsTheRunWithTheFramesSoFar) {
  for (int k = 0; k < 3; ++k) add_frame(k, 1'000 * (k + 1), static_cast<std::uint32_t>(k));
  device_->script.push_back(fake_event(FakeEvent::Kind::kDqbufError, ENODEV));
  CaptureLimits limits;
  limits.frames = 10;
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.stop, CaptureStop::kDisconnected);
  EXPECT_FALSE(r.ended_as_asked());
  EXPECT_EQ(r.frames, 3U);
  EXPECT_NE(r.describe().find("device disconnected"), std::string::npos) << r.describe();
}

TEST_F(StereoCapture, AStallEndsTheRunAfterTheTimeout) {
  add_frame(0, 1'000, 0);
  CaptureLimits limits;
  limits.frames = 10;
  limits.timeout_s = 0.05;
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.stop, CaptureStop::kTimeout);
  EXPECT_EQ(r.frames, 1U);
  EXPECT_NE(r.stop_message.find("no frame within 50 ms"), std::string::npos) << r.stop_message;
}

TEST_F(StereoCapture, TheDurationIsMeasuredOnTheCamerasClock) {
  for (int k = 0; k < 10; ++k) add_frame(k, 5'000'000 + 10'000 * k, static_cast<std::uint32_t>(k));
  CaptureLimits limits;
  limits.duration_s = 0.045;  // frames at 0, 10, 20, 30, 40 ms
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.stop, CaptureStop::kDuration);
  EXPECT_EQ(r.frames, 5U);
}

TEST_F(StereoCapture, OutOfOrderTimeStampsAreDropped) {
  add_frame(0, 2'000, 0);
  add_frame(1, 2'000, 1);
  add_frame(2, 1'000, 2);
  add_frame(3, 3'000, 3);
  CaptureLimits limits;
  limits.frames = 2;
  const CaptureReport r = run(limits);
  EXPECT_EQ(r.frames, 2U);
  EXPECT_EQ(r.out_of_order, 2U);
  EXPECT_EQ(received_[1].t_ns, sent_[3].t_ns);
}

TEST_F(StereoCapture, AnInterruptStopsTheRun) {
  add_frame(0, 1'000, 0);
  const std::atomic<bool> interrupt{true};
  const CaptureReport r = run({}, &interrupt);
  EXPECT_EQ(r.stop, CaptureStop::kInterrupted);
  EXPECT_EQ(r.frames, 0U);
}

TEST_F(StereoCapture, AStopPredicateEndsTheRunBetweenFrames) {
  for (int k = 0; k < 5; ++k) add_frame(k, 1'000 + 1'000 * k, static_cast<std::uint32_t>(k));
  V4l2Camera camera("/dev/fake0", device_);
  CameraOptions c;
  c.width = kWidth;
  c.height = kHeight;
  const auto format = camera.configure(c);
  std::size_t delivered = 0;
  kestrel::driver::CaptureHooks hooks;
  hooks.stop_requested = [&] { return delivered >= 2; };  // e.g. another pipeline stage failed
  const CaptureReport r = kestrel::driver::capture_stereo(
      camera, format, StereoFrameDecoder(options_), {},
      [&](TimeNs, const StereoMosaic&, std::span<const std::uint8_t>, std::size_t) { ++delivered; },
      hooks);
  EXPECT_EQ(r.stop, CaptureStop::kInterrupted);
  EXPECT_EQ(r.frames, 2U);
  EXPECT_EQ(device_->script.size(), 3U);  // the rest was never dequeued
  EXPECT_FALSE(camera.streaming());
}

TEST_F(StereoCapture, TheRecordingReadsBackAsAnEurocSequence) {
  const auto dir = kestrel::test::fresh_temp_dir("capture_record");
  options_.left_byte = 1;
  RecorderOptions ro;
  ro.images = ViewKind::kMosaic;  // lossless: the PNGs must hold the exact samples
  ro.raw = true;
  recorder_ = std::make_unique<StereoRecorder>(dir / "rec", options_, ro);
  for (int k = 0; k < 3; ++k) add_frame(k, 1'000'000 + 50'000 * k, static_cast<std::uint32_t>(k));
  CaptureLimits limits;
  limits.frames = 3;
  ASSERT_EQ(run(limits).frames, 3U);
  recorder_->finish();

  const kestrel::io::EurocSequence seq(dir / "rec");
  ASSERT_EQ(seq.stereo_size(), 3U);
  for (std::size_t k = 0; k < 3; ++k) {
    const auto pair = seq.load_stereo(k);
    EXPECT_EQ(pair.t_ns, sent_[k].t_ns);
    EXPECT_TRUE(identical(pair.left, sent_[k].left)) << k;
    EXPECT_TRUE(identical(pair.right, sent_[k].right)) << k;
    // The raw file is the packed frame without the row padding.
    const fs::path raw = dir / "rec" / "raw" / (std::to_string(sent_[k].t_ns) + ".bin");
    ASSERT_TRUE(fs::exists(raw));
    EXPECT_EQ(fs::file_size(raw), static_cast<std::uintmax_t>(2 * kWidth * kHeight));
    std::ifstream in(raw, std::ios::binary);
    std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
    EXPECT_EQ(bytes, kestrel::test::pack_by_hand(sent_[k].left, sent_[k].right, 1));
  }
  fs::remove_all(dir);
}

TEST(StereoRecorder, WritesGreyViewsAndGuardsTheFolder) {
  const auto dir = kestrel::test::fresh_temp_dir("recorder");
  StereoDecoderOptions o;
  o.width = 40;
  o.height = 30;
  const cv::Mat bgr = kestrel::test::smooth_bgr(40, 30);
  StereoMosaic m{kestrel::test::mosaic_by_hand(bgr, "GRBG"),
                 kestrel::test::mosaic_by_hand(bgr, "GRBG")};
  {
    StereoRecorder rec(dir / "out", o);
    rec.write(1'000, m);
    rec.write(2'000, m);
    EXPECT_THROW(rec.write(2'000, m), std::invalid_argument);  // names are time stamps
    rec.finish();
    EXPECT_THROW(rec.write(3'000, m), std::logic_error);
  }
  const kestrel::io::EurocSequence seq(dir / "out");
  ASSERT_EQ(seq.stereo_size(), 2U);
  cv::Mat expected;
  StereoFrameDecoder(o).convert(m.left, ViewKind::kGray, expected);
  EXPECT_TRUE(identical(seq.load_stereo(0).left, expected));

  // A second capture into the same folder replaces the first: no stale frames.
  {
    StereoRecorder rec(dir / "out", o);
    rec.write(5'000, m);
    rec.finish();
  }
  EXPECT_EQ(kestrel::io::EurocSequence(dir / "out").stereo_size(), 1U);
  EXPECT_FALSE(fs::exists(dir / "out" / "mav0" / "cam0" / "data" / "1000.png"));

  // A folder written by something else is refused without --force.
  fs::create_directories(dir / "mine");
  std::ofstream(dir / "mine" / "notes.txt") << "precious";
  EXPECT_THROW(StereoRecorder(dir / "mine", o), kestrel::InputError);
  EXPECT_TRUE(fs::exists(dir / "mine" / "notes.txt"));
  fs::remove_all(dir);
}

}  // namespace
