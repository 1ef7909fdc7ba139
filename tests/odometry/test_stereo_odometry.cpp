// StereoOdometry (rectify -> match -> disparity-space tracking): bad pairs are reported with
// their reason; with the semi-global matcher the still MAV of EuRoC V1_01's first part stays
// where it started (issue 30's drift target).
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <optional>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"
#include "test_data.hpp"

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

// The MAV stands still over the 60 pairs of V1_01_easy_part1: every pose must stay within 5 mm
// and 0.2 deg of the first (the target of issues 4 and 30; docs/stereo.md has the figures of
// both matchers). ~6 s on the 2-core CI host (SGM ~90 ms a pair).
TEST(StereoOdometry, SemiGlobalMatcherHoldsStillOnEurocV101) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const io::EurocSequence seq(test::shared_data_dir() / "euroc" / "V1_01_easy_part1");
  sensor::StereoFrontEndOptions front_end;
  front_end.kind = sensor::StereoMatcherKind::kSgm;
  StereoOdometry stereo(sensor::StereoCalibration::from_euroc(seq), front_end,
                        DirectTrackerOptions{});
  ASSERT_EQ(stereo.front_end().matcher().kind(), sensor::StereoMatcherKind::kSgm);
  ASSERT_GE(seq.stereo_size(), 60U);
  double max_m = 0.0, max_deg = 0.0, min_fill = 1.0;
  std::optional<SE3> first;
  for (std::size_t i = 0; i < seq.stereo_size(); ++i) {
    const auto pair = seq.load_stereo(i);
    const StereoTrackResult r = stereo.track(seq.stereo_timestamp(i), pair.left, pair.right);
    ASSERT_TRUE(r.track.ok()) << "pair " << i << ": " << r.track.failure_detail;
    min_fill = std::min(min_fill, r.match.fill_rate());
    if (!first) first = r.track.T_world_cam;
    const SE3 delta = first->inverse() * r.track.T_world_cam;
    max_m = std::max(max_m, delta.translation().norm());
    max_deg = std::max(max_deg, delta.so3().log().norm() * 180.0 / 3.14159265358979323846);
  }
  std::cout << "SGM odometry on V1_01_easy_part1: at most " << max_m * 1e3 << " mm and " << max_deg
            << " deg from the first pose, least fill " << 100.0 * min_fill << " %\n";
  EXPECT_LT(max_m, 5e-3);
  EXPECT_LT(max_deg, 0.2);
  EXPECT_GE(min_fill, 0.9);  // issue 30: fill >= 90 % on EuRoC V1_01
}

}  // namespace
}  // namespace kestrel::odometry
