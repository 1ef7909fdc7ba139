// StereoOdometry (rectify -> block match -> disparity-space tracking): bad pairs are reported
// with their reason.
#include <gtest/gtest.h>

#include <iostream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"

namespace kestrel::odometry {
namespace {

TEST(StereoOdometry, BadPairsAreReportedWithTheReason) {
  RectifiedStereo rig;
  rig.f = 105.0;
  rig.cu = 79.5;
  rig.cv = 59.5;
  rig.baseline_m = 0.12;
  rig.width = 160;
  rig.height = 120;
  sensor::BlockMatcherOptions m;
  m.max_disparity = 32;
  StereoOdometry stereo(rig, m, DirectTrackerOptions{});
  const cv::Mat left(120, 160, CV_8UC1, cv::Scalar(100));
  const StereoTrackResult a = stereo.track(0, left, cv::Mat(100, 160, CV_8UC1, cv::Scalar(100)));
  EXPECT_EQ(a.track.failure, TrackFailure::kInvalidInput);
  EXPECT_FALSE(a.track.failure_detail.empty());
  const StereoTrackResult b = stereo.track(0, cv::Mat(), cv::Mat());
  EXPECT_EQ(b.track.failure, TrackFailure::kInvalidInput);
  // A pair of another size than the rig's: the message names both sizes.
  const cv::Mat small(60, 80, CV_8UC1, cv::Scalar(100));
  const StereoTrackResult c = stereo.track(0, small, small);
  EXPECT_EQ(c.track.failure, TrackFailure::kInvalidInput);
  EXPECT_NE(c.track.failure_detail.find("160x120"), std::string::npos) << c.track.failure_detail;
  // Invalid matcher options are an InputError naming the field.
  m.block_size = 4;
  try {
    StereoOdometry bad(rig, m, DirectTrackerOptions{});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("block"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel::odometry
