// Rolling-shutter compensation (RollingShutter::readout_s, from the camera description) on a
// rendered sequence whose rows were each seen at their own time: the known motion is recovered
// with the model and is biased without it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/image/rolling_shutter.hpp"
#include "kestrel/image/undistortion.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "synthetic_rgbd.hpp"

namespace kestrel::odometry {
namespace {

constexpr double kFrameDt = 1.0 / 30.0;

// T_world_cam(t) = T0 exp(xi t): a constant twist (camera frame), fast like fr1/rpy.
SE3 pose_at(double t) {
  Vector6d xi;
  xi << 0.04, -0.02, 0.03, 0.5, 1.0, 0.4;  // m/s, rad/s (|w| = 1.2 rad/s, 69 deg/s)
  Vector6d x0;
  x0 << 0.05, 0.02, 0.0, 0.0, 0.0, 0.0;
  return SE3::exp(x0) * SE3::exp(xi * t);
}

struct RunErrors {
  double max_rotation_deg = 0.0;
  double max_translation_m = 0.0;
};

// Tracks frames rendered with the given readout (row v at t_k + readout (v - v_mid) / H) and
// compares each pose with the true pose at the frame's time (the middle row's).
RunErrors track(double render_readout_s, double model_readout_s, bool bicubic = true) {
  const PinholeCamera cam = test::test_camera();
  const auto room = test::make_room();
  DirectTrackerOptions o;
  o.solver.bicubic_finest_level = bicubic;
  DirectTracker tracker(cam, o, RollingShutter{model_readout_s});
  RunErrors e;
  const SE3 T_world_first = pose_at(0.0);
  const double v_mid = 0.5 * (cam.height() - 1);
  for (int k = 0; k < 10; ++k) {
    const double t = k * kFrameDt;
    const auto frame = test::render_rows(
        room, cam,
        [&](int v) { return pose_at(t + render_readout_s * (v - v_mid) / cam.height()); },
        s_to_ns(t));
    const TrackResult r = tracker.track(frame);
    EXPECT_TRUE(r.ok()) << "frame " << k << ": " << r.failure_detail;
    const SE3 truth = T_world_first.inverse() * pose_at(t);
    e.max_rotation_deg =
        std::max(e.max_rotation_deg, test::rotation_error_deg(r.T_world_cam, truth));
    e.max_translation_m =
        std::max(e.max_translation_m, test::translation_error_m(r.T_world_cam, truth));
  }
  return e;
}

double rms_difference(const cv::Mat& a, const cv::Mat& b, int border) {
  double e = 0.0;
  int n = 0;
  for (int v = border; v < a.rows - border; ++v) {
    for (int u = border; u < a.cols - border; ++u) {
      const double d = a.at<float>(v, u) - b.at<float>(v, u);
      e += d * d;
      ++n;
    }
  }
  return std::sqrt(e / n);
}

TEST(RollingShutter, RectifiedImageMatchesTheGlobalShutterImage) {
  const PinholeCamera cam = test::test_camera();
  const auto room = test::make_room();
  const double t = 0.1, readout = 0.03, v_mid = 0.5 * (cam.height() - 1);
  const auto global = test::render(room, cam, pose_at(t));
  const auto rolling = test::render_rows(
      room, cam, [&](int v) { return pose_at(t + readout * (v - v_mid) / cam.height()); });
  image::RollingShutterRectifier rectifier(cam, readout);
  Vector6d xi = (pose_at(0.0).inverse() * pose_at(1.0)).log();  // the constant twist
  rectifier.set_rotation_rate(xi.tail<3>());
  cv::Mat rectified;
  rectifier.rectify_intensity(rolling.image, rectified);
  const double before = rms_difference(rolling.image, global.image, 20);
  const double after = rms_difference(rectified, global.image, 20);
  EXPECT_LT(after, 0.2 * before) << "before " << before << ", after " << after;
  // No rotation, no lens distortion: the identity (to float rounding of the map).
  rectifier.set_rotation_rate(Eigen::Vector3d::Zero());
  rectifier.rectify_intensity(rolling.image, rectified);
  EXPECT_LT(rms_difference(rectified, rolling.image, 1), 1e-5);
}

TEST(RollingShutter, ZeroRateMapsUndistortLikeTheUndistorter) {
  // With a lens: the zero-rate maps are the undistortion maps (cv::initUndistortRectifyMap).
  const PinholeCamera fr1({517.3, 516.5, 318.6, 255.3, 640, 480},
                          {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  cv::Mat raw(480, 640, CV_32FC1);
  for (int v = 0; v < raw.rows; ++v) {
    for (int u = 0; u < raw.cols; ++u) {
      raw.at<float>(v, u) = static_cast<float>(0.5 + 0.3 * std::sin(0.05 * u) * std::cos(0.04 * v));
    }
  }
  image::RollingShutterRectifier rectifier(fr1, 0.02);
  cv::Mat ours, reference;
  rectifier.rectify_intensity(raw, ours);
  image::Undistorter(fr1).undistort_intensity(raw, reference);
  // The undistorter's fixed-point maps are exact to 1/32 px: 1/32 px of this texture's slope.
  const double rms = rms_difference(ours, reference, 10);
  EXPECT_LT(rms, 2e-3);
  // ... and not the identity: the lens moves pixels by up to ~10 px here.
  EXPECT_GT(rms_difference(raw, reference, 10), 20 * rms) << rms;
}

// With the defaults (bicubic finest level, so a bicubic rectifier) and with bilinear sampling
// (a bilinear rectifier). Measured: 0.101 deg / 5.8 mm and 0.111 deg / 7.0 mm against the global
// shutter model's 0.68 deg / 17-18 mm; a rectifier kernel that does not match the tracker's
// sampling gives 0.17-0.19 deg (rolling_shutter.hpp, the constructor).
class RollingShutterModel : public ::testing::TestWithParam<bool> {};

TEST_P(RollingShutterModel, RecoversTheMotionThatAGlobalShutterModelBiases) {
  const bool bicubic = GetParam();
  const double readout = 0.03;
  const RunErrors global = track(readout, 0.0, bicubic);
  const RunErrors modelled = track(readout, readout, bicubic);
  std::printf(
      "rolling shutter 30 ms, 10 frames at 69 deg/s, %s: global-shutter model %.3f deg / "
      "%.2f mm, rolling-shutter model %.3f deg / %.2f mm\n",
      bicubic ? "bicubic" : "bilinear", global.max_rotation_deg, 1e3 * global.max_translation_m,
      modelled.max_rotation_deg, 1e3 * modelled.max_translation_m);
  EXPECT_LT(modelled.max_rotation_deg, 0.25 * global.max_rotation_deg);
  EXPECT_LT(modelled.max_translation_m, 0.6 * global.max_translation_m);
}

INSTANTIATE_TEST_SUITE_P(Sampling, RollingShutterModel, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return i.param ? std::string("BicubicFinestLevel")
                                          : std::string("Bilinear");
                         });

TEST(RollingShutter, WithoutRollingShutterTheSequenceIsTrackedExactly) {
  // The control: the same motion rendered with a global shutter, tracked with the default.
  const RunErrors a = track(0.0, 0.0);
  EXPECT_LT(a.max_rotation_deg, 0.05);
  EXPECT_LT(a.max_translation_m, 1e-3);
}

TEST(RollingShutter, InvalidReadoutIsRejectedByName) {
  try {
    DirectTracker tracker(test::test_camera(), {}, RollingShutter{-0.01});
    FAIL() << "negative readout accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("readout"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel::odometry
