// Relocalizer on rendered pairs with known motions of 20-30 cm and no guess: the SIFT + PnP
// guess and the direct refinement recover them; pairs that share nothing are refused; bad
// options and input are reported. (On the flight's office frames, where the direct alignment
// alone does not reach such offsets: tests/flight/test_relocalization.cpp.)
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/relocalizer.hpp"
#include "synthetic_rgbd.hpp"

namespace kestrel::odometry {
namespace {

using test::motion;
using test::render;
using test::rotation_error_deg;
using test::test_camera;
using test::translation_error_m;

struct Case {
  const char* name;
  SE3 T_ref_cur;
};

const std::vector<Case>& cases() {
  static const std::vector<Case> c = {
      {"25 cm sideways", motion(0.25, 0, 0, 0, 0, 0)},
      {"20 cm down, 10 cm back", motion(0, 0.20, -0.10, 0, 0, 0)},
      {"30 cm diagonal, 3 deg yaw", motion(-0.2, -0.15, 0.15, 0, 3, 0)},
      {"all axes", motion(0.15, 0.12, -0.1, 2.0, -2.5, 1.5)},
  };
  return c;
}

class KnownOffset : public ::testing::TestWithParam<int> {};

TEST_P(KnownOffset, IsRecoveredWithoutAGuess) {
  const Case& c = cases()[static_cast<std::size_t>(GetParam())];
  const auto cam = test_camera();
  const auto room = test::make_room();
  const SE3 T_world_ref = motion(0.05, 0.02, 0, 0, 0, 0);
  const RgbdFrame ref = render(room, cam, T_world_ref, 1'000'000'000);
  const RgbdFrame cur = render(room, cam, T_world_ref * c.T_ref_cur, 3'000'000'000);

  Relocalizer relocalizer(cam, RelocalizerOptions{}, DirectTrackerOptions{});
  const RelocalizationResult r = relocalizer.relocalize(ref, cur);
  ASSERT_TRUE(r.ok()) << c.name << ": " << r.detail;
  EXPECT_GE(r.inliers, RelocalizerOptions{}.min_inliers) << c.name;
  // The PnP guess is within the direct alignment's basin; the refinement is at its accuracy
  // (the tracker's own known-motion test asks 1 mm and 0.05 deg for small motions).
  EXPECT_LT(translation_error_m(r.T_ref_cur_pnp, c.T_ref_cur), 0.03) << c.name;
  EXPECT_LT(translation_error_m(r.T_ref_cur, c.T_ref_cur), 2e-3) << c.name;
  EXPECT_LT(rotation_error_deg(r.T_ref_cur, c.T_ref_cur), 0.1) << c.name;
  EXPECT_TRUE(r.covariance.allFinite());
  EXPECT_GT(r.covariance.diagonal().minCoeff(), 0.0);
  EXPECT_EQ(r.refinement.ref_t_ns, ref.t_ns);
  EXPECT_EQ(r.refinement.t_ns, cur.t_ns);
}
INSTANTIATE_TEST_SUITE_P(Cases, KnownOffset, ::testing::Range(0, 4));

TEST(Relocalizer, FramesThatShareNothingAreRefused) {
  const auto cam = test_camera();
  const RgbdFrame ref = render(test::make_room(1), cam, SE3());
  Relocalizer relocalizer(cam, RelocalizerOptions{}, DirectTrackerOptions{});
  // The same room seen from the opposite direction, and another room at the same pose.
  const RgbdFrame away = render(test::make_room(1), cam, motion(0, 0, 1.0, 0, 180, 0));
  const RelocalizationResult r1 = relocalizer.relocalize(ref, away);
  EXPECT_FALSE(r1.ok());
  EXPECT_NE(r1.detail, "");
  const RgbdFrame other = render(test::make_room(50), cam, SE3());
  const RelocalizationResult r2 = relocalizer.relocalize(ref, other);
  EXPECT_FALSE(r2.ok()) << "inliers " << r2.inliers << " of " << r2.matches;
}

TEST(Relocalizer, BadInputAndOptionsAreReported) {
  const auto cam = test_camera();
  Relocalizer relocalizer(cam, RelocalizerOptions{}, DirectTrackerOptions{});
  RgbdFrame empty;
  const RgbdFrame ref = render(test::make_room(1), cam, SE3());
  EXPECT_EQ(relocalizer.relocalize(ref, empty).failure, RelocalizationFailure::kInvalidInput);
  RgbdFrame small = ref;
  small.image = ref.image(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_EQ(relocalizer.relocalize(small, ref).failure, RelocalizationFailure::kInvalidInput);

  RelocalizerOptions o;
  o.min_inliers = 3;
  EXPECT_THROW(o.validate(), InputError);
  o = RelocalizerOptions{};
  o.max_match_ratio = 1.5;
  EXPECT_THROW(o.validate(), InputError);
  o = RelocalizerOptions{};
  o.sift_contrast_threshold = 0.0;
  EXPECT_THROW(o.validate(), InputError);
  o = RelocalizerOptions{};
  o.max_depth_m = o.min_depth_m;
  EXPECT_THROW(Relocalizer(cam, o, DirectTrackerOptions{}), InputError);
  const PinholeCamera distorted({262.5, 262.5, 159.5, 119.5, 320, 240}, {0.1, 0, 0, 0, 0});
  EXPECT_THROW(Relocalizer(distorted, RelocalizerOptions{}, DirectTrackerOptions{}), InputError);
}

}  // namespace
}  // namespace kestrel::odometry
