// The pipeline from the camera: a stand-in V4L2 device (tests/driver/fake_v4l2_device.hpp, the
// driver tests' seam) plays packed Bayer-in-YUYV frames built from a known textured scene,
// with the faults the issue lists (truncated frame, unplugging, stall, wrong pixel format,
// full queues, stop requests); a missing device is a clear error; a v4l2loopback device, where
// there is one, runs the real kernel path. Checks counts and poses, never timings.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "camera_test_files.hpp"
#include "fake_v4l2_device.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/driver/bayer.hpp"
#include "kestrel/pipeline/pipeline.hpp"
#include "pipeline_report.hpp"
#include "run_cli.hpp"
#include "stereo_test_frames.hpp"
#include "test_data.hpp"
#include "v4l2_loopback_device.hpp"

namespace kestrel::pipeline {
namespace {

namespace fs = std::filesystem;
using test::fake_event;
using test::fake_frame;
using test::FakeEvent;
using test::stage;

constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr int kDisparity = 8;  // px: a fronto-parallel wall at f * B / d = 300 * 0.1 / 8 m

/// A textured wall seen by both cameras: smoothed noise for the left view, the right view the
/// same shifted by kDisparity (a point at left x is at right x - d).
struct Scene {
  cv::Mat left, right;
};
Scene textured_wall(int width, int height) {
  cv::Mat noise(height, width + kDisparity, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  Scene s;
  s.left = noise(cv::Rect(0, 0, width, height)).clone();
  s.right = noise(cv::Rect(kDisparity, 0, width, height)).clone();
  return s;
}

/// The packed frame the LI-USB30-V024STEREO would send of `scene`: each view sampled through
/// the GRBG filter, the two mosaics interleaved byte by byte (left in byte 0), rows `stride`
/// bytes apart — built by the driver tests' hand packer, not by the decoder under test.
std::vector<std::uint8_t> packed_frame(const Scene& scene, std::size_t stride = 0) {
  cv::Mat left_bgr, right_bgr;
  cv::cvtColor(scene.left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(scene.right, right_bgr, cv::COLOR_GRAY2BGR);
  return test::pack_by_hand(test::mosaic_by_hand(left_bgr, "GRBG"),
                            test::mosaic_by_hand(right_bgr, "GRBG"), 0, stride);
}

/// The stand-in device as a camera that streams for ever at about 50 Hz: whenever its script
/// is spent, the next frame is queued (same picture, increasing stamps).
class EndlessCamera final : public driver::DeviceIo {
 public:
  EndlessCamera(std::shared_ptr<test::FakeV4l2Device> device, std::vector<std::uint8_t> frame)
      : device_(std::move(device)), frame_(std::move(frame)) {}
  int open(const std::string& path) override { return device_->open(path); }
  int close(int fd) override { return device_->close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override {
    return device_->ioctl(fd, request, arg);
  }
  int poll(int fd, int timeout_ms, short& revents) override {
    if (device_->script.empty()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      device_->script.push_back(fake_frame(frame_, 1'000'000 + 20'000 * next_, next_));
      ++next_;
    }
    return device_->poll(fd, timeout_ms, revents);
  }
  void* mmap(int fd, std::size_t length, std::int64_t offset) override {
    return device_->mmap(fd, length, offset);
  }
  int munmap(void* address, std::size_t length) override {
    return device_->munmap(address, length);
  }

 private:
  std::shared_ptr<test::FakeV4l2Device> device_;
  std::vector<std::uint8_t> frame_;
  std::uint32_t next_ = 0;
};

class CameraPipeline : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("camera_pipeline");
    test::write_pinhole_pair(dir_ / "calib.yaml", kWidth, kHeight);
    device_->formats = {{V4L2_PIX_FMT_YUYV, {{kWidth, kHeight}}}};
    device_->padding_per_line = 32;  // padded rows, as some drivers deliver them
    frame_ = packed_frame(textured_wall(kWidth, kHeight), 2 * kWidth + 32);
  }
  void TearDown() override { fs::remove_all(dir_); }

  PipelineOptions options(const std::string& extra = "", const std::string& camera = "") const {
    return PipelineOptions::load_yaml(test::write_text(
        dir_ / "run.yaml", "source: camera\ncamera:\n  device: /dev/fake-stereo\n  width: " +
                               std::to_string(kWidth) + "\n  height: " + std::to_string(kHeight) +
                               "\n  calibration: calib.yaml\n  timeout_s: 0.3\n" + camera + extra));
  }
  /// Frame k of the script, 33 ms apart on the camera's clock; `cut` bytes short if given.
  void add_frame(int k, std::size_t cut = 0) {
    auto bytes = frame_;
    bytes.resize(bytes.size() - cut);
    device_->script.push_back(
        fake_frame(bytes, 1'000'000 + 33'333 * k, static_cast<std::uint32_t>(k)));
  }
  PipelineReport run(const PipelineOptions& o, const std::atomic<bool>* stop = nullptr) {
    PipelineEnvironment env;
    env.camera_io = device_;
    env.log = &log_;
    return run_pipeline(o, stop, env);
  }

  fs::path dir_;
  std::shared_ptr<test::FakeV4l2Device> device_ = std::make_shared<test::FakeV4l2Device>();
  std::vector<std::uint8_t> frame_;
  std::ostringstream log_;
};

TEST_F(CameraPipeline, PairsReachTheDepthStageAndATruncatedFrameIsCountedAndSkipped) {
  for (int k = 0; k < 6; ++k) add_frame(k, k == 2 ? 1000 : 0);  // frame 2 is cut short
  // Blocking queues: every good frame must reach every stage.
  const PipelineReport r = run(options("max_frames: 5\ndrop_stale: false\n"));
  ASSERT_TRUE(r.camera.has_value());
  EXPECT_EQ(r.camera->stop, driver::CaptureStop::kFrames) << r.camera->describe();
  EXPECT_EQ(r.camera->frames, 5u);
  EXPECT_EQ(r.camera->truncated, 1u);
  EXPECT_NE(log_.str().find("truncated"), std::string::npos) << log_.str();
  const auto& src = stage(r, "source");
  EXPECT_EQ(src.in, 6u);
  EXPECT_EQ(src.failed, 1u);
  EXPECT_EQ(src.out, 5u);
  EXPECT_EQ(r.stereo_pairs, 5u);
  EXPECT_EQ(stage(r, "depth").in, 5u);
  EXPECT_EQ(stage(r, "depth").dropped, 0u);
  EXPECT_EQ(stage(r, "depth").failed, 0u);  // the wall is textured: disparities everywhere
  EXPECT_EQ(stage(r, "tracker").in, 5u);
  EXPECT_EQ(stage(r, "tracker").failed, 0u);
  // No IMU: the odometry passes through, one state per tracked pair, flagged.
  EXPECT_TRUE(r.fusion_pass_through);
  EXPECT_EQ(r.imu_samples, 0u);
  ASSERT_EQ(r.states.size(), 5u);
  EXPECT_EQ(stage(r, "controller").in, 5u);
  // The camera's own time stamps, and the truncated frame's missing from them.
  EXPECT_EQ(r.states[0].t_ns, 1'000'000'000);
  EXPECT_EQ(r.states[2].t_ns, (1'000'000 + 33'333 * 3) * 1000LL);
  // The same view every time: the camera has not moved.
  for (const auto& s : r.states) {
    EXPECT_LT(s.state.p_world.norm(), 0.01);
    EXPECT_LT(s.state.q_world_body.angularDistance(Eigen::Quaterniond::Identity()), 0.01);
    EXPECT_TRUE(std::isnan(s.sigma[0]));  // no covariance is claimed
  }
  // Unfused states are not flown by default: every controller output is the motors-off PWM.
  EXPECT_TRUE(r.controller_disarmed);
  std::size_t per_state = 0;
  for (const auto& c : r.controller) {
    per_state += c.input != ControllerInput::kNoState;
    EXPECT_TRUE(c.disarmed);
    EXPECT_TRUE(c.motors_off);
    EXPECT_EQ(c.pwm, control::PwmMapper().motors_off());
  }
  EXPECT_EQ(per_state, 5u);
  EXPECT_EQ(device_->unmaps, device_->maps);  // the camera was stopped
}

TEST_F(CameraPipeline, AnUnpluggedCameraEndsTheRunCleanlyWithWhatItGave) {
  for (int k = 0; k < 3; ++k) add_frame(k);
  device_->script.push_back(fake_event(FakeEvent::Kind::kDqbufError, ENODEV));
  add_frame(3);  // never seen: the device is gone
  const PipelineReport r = run(options("drop_stale: false\n"));
  ASSERT_TRUE(r.camera.has_value());
  EXPECT_EQ(r.camera->stop, driver::CaptureStop::kDisconnected);
  EXPECT_FALSE(r.camera->ended_as_asked());
  EXPECT_FALSE(r.interrupted);
  EXPECT_EQ(stage(r, "depth").in, 3u);
  EXPECT_EQ(r.states.size(), 3u);
}

TEST_F(CameraPipeline, AStalledCameraTimesOutInsteadOfHanging) {
  for (int k = 0; k < 2; ++k) add_frame(k);  // then silence
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineReport r = run(options("drop_stale: false\n"));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.camera.has_value());
  EXPECT_EQ(r.camera->stop, driver::CaptureStop::kTimeout);
  EXPECT_EQ(stage(r, "depth").in, 2u);
  EXPECT_LT(s, 30.0);  // timeout_s is 0.3; generous for a loaded machine
}

TEST_F(CameraPipeline, FullQueuesDropTheOldestPairsAndTheCountsAddUp) {
  // The stand-in delivers frames as fast as they are asked for: far faster than the depth stage.
  for (int k = 0; k < 30; ++k) add_frame(k);
  const PipelineReport r = run(options("max_frames: 30\nframe_queue_capacity: 1\n"));
  EXPECT_TRUE(r.camera && r.camera->stop == driver::CaptureStop::kFrames);
  const auto& src = stage(r, "source");
  const auto& depth = stage(r, "depth");
  const auto& tracker = stage(r, "tracker");
  EXPECT_EQ(src.out, 30u);
  // Every pair handed on was either taken or dropped as stale; nothing is lost unaccounted.
  EXPECT_EQ(src.out, depth.in + depth.dropped);
  EXPECT_EQ(depth.out, tracker.in + tracker.dropped);
  EXPECT_GT(depth.in, 0u);
  EXPECT_EQ(stage(r, "controller").in, r.states.size());
}

TEST_F(CameraPipeline, AStopRequestEndsTheRunCleanly) {
  for (int k = 0; k < 5; ++k) add_frame(k);
  const std::atomic<bool> stop{true};  // Ctrl-C before the first frame
  const PipelineReport r = run(options(), &stop);
  ASSERT_TRUE(r.camera.has_value());
  EXPECT_EQ(r.camera->stop, driver::CaptureStop::kInterrupted);
  EXPECT_TRUE(r.interrupted);
  EXPECT_EQ(r.stereo_pairs, 0u);
  for (const auto& s : r.stages) EXPECT_EQ(s.out, 0u) << s.name;

  // From another thread mid-run, with a camera that never stops by itself.
  PipelineEnvironment env;
  env.camera_io = std::make_shared<EndlessCamera>(device_, frame_);
  std::atomic<bool> later{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    later = true;
  });
  const PipelineReport r2 = run_pipeline(options(), &later, env);
  stopper.join();
  ASSERT_TRUE(r2.camera.has_value());
  EXPECT_EQ(r2.camera->stop, driver::CaptureStop::kInterrupted) << r2.camera->describe();
  EXPECT_TRUE(r2.interrupted);
  EXPECT_GT(r2.stereo_pairs, 0u);
  EXPECT_EQ(stage(r2, "source").out, stage(r2, "depth").in + stage(r2, "depth").dropped);
}

TEST_F(CameraPipeline, AWrongPixelFormatIsAnErrorNamingTheConfigAndTheFormats) {
  device_->forced_fourcc = V4L2_PIX_FMT_MJPEG;
  try {
    (void)run(options());
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find((dir_ / "run.yaml").string() + ": field 'camera'"), std::string::npos) << m;
    EXPECT_NE(m.find("/dev/fake-stereo"), std::string::npos) << m;
    EXPECT_NE(m.find("wrong pixel format"), std::string::npos) << m;
  }
}

constexpr const char* kMissing = "/dev/video-kestrel-none";

TEST_F(CameraPipeline, AMissingDeviceIsAClearErrorNamingItsPath) {
  PipelineOptions o = options();
  o.camera.device = kMissing;
  try {
    (void)run_pipeline(o);  // the real system calls
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("field 'camera.device'"), std::string::npos) << m;
    EXPECT_NE(m.find(std::string(kMissing) + ": no such video device"), std::string::npos) << m;
  }
}

TEST_F(CameraPipeline, TheCommandExitsNonZeroForAMissingDeviceAndWritesNothing) {
  ASSERT_TRUE(fs::exists(KESTREL_BINARY)) << KESTREL_BINARY << " not found: build `kestrel`";
  const fs::path config = test::write_text(
      dir_ / "cam.yaml", std::string("source: camera\ncamera:\n  device: ") + kMissing +
                             "\n  width: 320\n  height: 240\n  calibration: calib.yaml\n");
  const test::RunResult r =
      test::run_kestrel(dir_, "run --config " + test::quoted(config.string()) + " --out " +
                                  test::quoted((dir_ / "out").string()));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(config.string() + ": field 'camera.device': " + kMissing +
                       ": no such video device"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "out"));  // checked before the output folder is claimed
}

TEST(CameraPipelineLoopback, RunsFromAV4l2LoopbackDevice) {
  const test::LoopbackSearch search = test::find_loopback();
  if (!search.device) GTEST_SKIP() << "no v4l2loopback device: " << search.why_not;
  const fs::path dir = test::fresh_temp_dir("camera_loopback");
  test::write_pinhole_pair(dir / "calib.yaml", 752, 480);
  const test::LoopbackWriter writer(*search.device, {packed_frame(textured_wall(752, 480))});
  PipelineOptions o = PipelineOptions::load_yaml(test::write_text(
      dir / "run.yaml", "source: camera\ncamera:\n  device: " + *search.device +
                            "\n  calibration: calib.yaml\nmax_frames: 5\ndrop_stale: false\n"));
  const PipelineReport r = run_pipeline(o);
  ASSERT_TRUE(r.camera.has_value());
  EXPECT_EQ(r.camera->stop, driver::CaptureStop::kFrames) << r.camera->describe();
  EXPECT_EQ(stage(r, "depth").in, 5u);
  EXPECT_EQ(r.states.size(), 5u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::pipeline
