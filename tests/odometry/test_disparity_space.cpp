// Disparity-space odometry (thesis 2.4, 3.6-3.7, 3.10): the warp and its Jacobian against
// central differences, the per-level baseline, the per-level disparity, the tracker fed by
// disparity maps, and its errors on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/disparity_space.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"
#include "synthetic_rgbd.hpp"

namespace kestrel::odometry {
namespace {

using test::motion;

RectifiedStereo random_rig(std::mt19937& rng) {
  std::uniform_real_distribution<double> f(300.0, 600.0), b(0.05, 0.3);
  RectifiedStereo rig;
  rig.f = f(rng);
  rig.width = 640;
  rig.height = 480;
  rig.cu = 319.5 + std::uniform_real_distribution<double>(-10.0, 10.0)(rng);
  rig.cv = 239.5 + std::uniform_real_distribution<double>(-10.0, 10.0)(rng);
  rig.baseline_m = b(rng);
  return rig;
}

RectifiedStereo test_rig() {
  const PinholeCamera cam = test::test_camera();
  RectifiedStereo rig;
  rig.f = cam.fx();
  rig.cu = cam.cx();
  rig.cv = cam.cy();
  rig.baseline_m = 0.1;
  rig.width = cam.width();
  rig.height = cam.height();
  return rig;
}

// A rendered RGB-D frame of the test room as a disparity frame (exact d = B f / Z).
DisparityFrame to_disparity_frame(const RgbdFrame& f, const RectifiedStereo& rig) {
  DisparityFrame out;
  out.t_ns = f.t_ns;
  out.image = f.image;
  out.disparity_px.create(f.depth_m.size(), CV_32FC1);
  for (int v = 0; v < f.depth_m.rows; ++v) {
    for (int u = 0; u < f.depth_m.cols; ++u) {
      const float z = f.depth_m.at<float>(v, u);
      out.disparity_px.at<float>(v, u) = z > 0.0F ? static_cast<float>(rig.disparity_from_depth(z))
                                                  : std::numeric_limits<float>::infinity();
    }
  }
  return out;
}

// --- warp and Jacobian -------------------------------------------------------------------

TEST(DisparitySpace, WarpJacobianMatchesCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const RectifiedStereo rig = random_rig(rng);
    const int level = trial % 4;
    const DisparitySpaceCamera cam = DisparitySpaceCamera::at_level(rig, level);
    const double u = unit(rng) * (rig.width >> level);
    const double v = unit(rng) * (rig.height >> level);
    const double d = 1.0 + 80.0 * unit(rng);  // full-resolution pixels on every level
    const Eigen::Vector3d uvd(u, v, d);
    const Eigen::Matrix<double, 3, 6> J = disparity_warp_jacobian(cam, u, v, d);
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vector6d e = Vector6d::Zero();
      e(k) = h;
      const Eigen::Vector3d numeric =
          (disparity_warp(cam, uvd, SE3::exp(e)) - disparity_warp(cam, uvd, SE3::exp(-e))) /
          (2.0 * h);
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(J(r, k), numeric(r), 1e-5 * std::max(1.0, std::abs(numeric(r))))
            << "row " << r << " column " << k << " level " << level;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 1200);
}

TEST(DisparitySpace, PhotometricRowIsGradientTimesWarpJacobianAndMatchesDepthForm) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0), grad(-0.2, 0.2);
  for (int trial = 0; trial < 200; ++trial) {
    const RectifiedStereo rig = random_rig(rng);
    const int level = trial % 4;
    const DisparitySpaceCamera cam = DisparitySpaceCamera::at_level(rig, level);
    const double u = unit(rng) * (rig.width >> level);
    const double v = unit(rng) * (rig.height >> level);
    const double d = 1.0 + 80.0 * unit(rng);
    const double gx = grad(rng), gy = grad(rng);
    const Eigen::Matrix<double, 1, 6> J = disparity_photometric_pose_jacobian(cam, u, v, d, gx, gy);
    const Eigen::Matrix<double, 1, 6> chain =
        Eigen::RowVector2d(gx, gy) * disparity_warp_jacobian(cam, u, v, d).topRows<2>();
    // The RGB-D form (warp_jacobian.hpp) at the same 3D point: two derivations agree.
    const Eigen::Matrix<double, 1, 6> depth_form =
        photometric_pose_jacobian(cam.point(u, v, d), gx, gy, cam.f, cam.f);
    for (int k = 0; k < 6; ++k) {
      const double tol = 1e-9 * std::max(1.0, std::abs(chain(k)));
      EXPECT_NEAR(J(k), chain(k), tol) << "column " << k;
      EXPECT_NEAR(J(k), depth_form(k), tol) << "column " << k;
    }
  }
}

TEST(DisparitySpace, WarpIsTheMovedPointAndGammaInvertsPoint) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0), small(-0.2, 0.2);
  for (int trial = 0; trial < 100; ++trial) {
    const RectifiedStereo rig = random_rig(rng);
    const DisparitySpaceCamera cam = DisparitySpaceCamera::at_level(rig, trial % 4);
    const Eigen::Vector3d uvd(unit(rng) * 100.0, unit(rng) * 100.0, 2.0 + 50.0 * unit(rng));
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi(k) = small(rng);
    const SE3 T = SE3::exp(xi);
    const Eigen::Vector3d P = cam.point(uvd.x(), uvd.y(), uvd.z());
    EXPECT_LT((cam.to_disparity_space(P) - uvd).norm(), 1e-9);
    const Eigen::Vector3d expected = cam.to_disparity_space(T * P);
    EXPECT_LT((disparity_warp(cam, uvd, T) - expected).norm(), 1e-8 * expected.norm());
  }
}

TEST(DisparitySpace, ScaledBaselineKeepsDepthOnEveryLevel) {
  // Thesis 3.10: d stays in full-resolution pixels, B_l = 2^l B, so a level-l pixel at the
  // position of a full-resolution pixel gives the same 3D point from the same disparity.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const RectifiedStereo rig = random_rig(rng);
    const DisparitySpaceCamera c0 = DisparitySpaceCamera::at_level(rig, 0);
    const double u = unit(rng) * 639.0, v = unit(rng) * 479.0, d = 1.0 + 60.0 * unit(rng);
    const Eigen::Vector3d P0 = c0.point(u, v, d);
    EXPECT_NEAR(P0.z(), rig.depth_from_disparity(d), 1e-9 * P0.z());
    for (int l = 1; l < 5; ++l) {
      const DisparitySpaceCamera cl = DisparitySpaceCamera::at_level(rig, l);
      const double s = 1.0 / (1 << l);
      const Eigen::Vector3d Pl = cl.point((u + 0.5) * s - 0.5, (v + 0.5) * s - 0.5, d);
      EXPECT_LT((Pl - P0).norm(), 1e-9 * P0.norm()) << "level " << l;
    }
  }
}

// --- per-level disparity --------------------------------------------------------------------

TEST(DisparitySpace, LevelDisparityIsThePlanesDisparityAtThePixelCentre) {
  // A plane's disparity is affine in (u, v): the 2x2 mean is exact at the level pixel's centre.
  cv::Mat d(64, 80, CV_32FC1);
  auto plane = [](double u, double v) { return 20.0 + 0.05 * u - 0.03 * v; };
  for (int v = 0; v < d.rows; ++v) {
    for (int u = 0; u < d.cols; ++u) d.at<float>(v, u) = static_cast<float>(plane(u, v));
  }
  cv::Mat out;
  for (int l = 0; l < 4; ++l) {
    disparity_at_level(d, l, 0.03F, out);
    ASSERT_EQ(out.cols, d.cols >> l);
    ASSERT_EQ(out.rows, d.rows >> l);
    const double s = 1 << l;
    for (int v = 0; v < out.rows; ++v) {
      for (int u = 0; u < out.cols; ++u) {
        EXPECT_NEAR(out.at<float>(v, u), plane((u + 0.5) * s - 0.5, (v + 0.5) * s - 0.5), 1e-4)
            << "level " << l << " at " << u << "," << v;
      }
    }
  }
}

TEST(DisparitySpace, LevelDisparityIsNotInterpolatedAcrossOcclusionsOrHoles) {
  cv::Mat d(32, 32, CV_32FC1, cv::Scalar(10.0F));
  d.colRange(16, 32).setTo(20.0F);  // an occlusion boundary between columns 15 and 16
  d.at<float>(5, 5) = std::numeric_limits<float>::infinity();  // a hole (kNoDisparity)
  d.at<float>(9, 9) = std::numeric_limits<float>::quiet_NaN();
  cv::Mat out;
  disparity_at_level(d, 0, 0.03F, out);
  EXPECT_EQ(out.at<float>(5, 5), 0.0F);
  EXPECT_EQ(out.at<float>(9, 9), 0.0F);
  EXPECT_EQ(out.at<float>(0, 16), 20.0F);
  disparity_at_level(d, 1, 0.03F, out);
  EXPECT_EQ(out.at<float>(2, 2), 0.0F);  // holds the hole (5, 5): full-res rows/cols 4..5
  EXPECT_EQ(out.at<float>(0, 7), 10.0F);
  EXPECT_EQ(out.at<float>(0, 8), 20.0F);
  disparity_at_level(d, 2, 0.03F, out);
  // Level-2 pixel 3 reads full-res columns 13, 14; pixel 4 reads 17, 18: one surface each.
  EXPECT_EQ(out.at<float>(0, 3), 10.0F);
  EXPECT_EQ(out.at<float>(0, 4), 20.0F);
  disparity_at_level(d, 3, 0.03F, out);
  // Level-3 pixel 1 reads columns 11, 12; pixel 2 reads 19, 20.
  EXPECT_EQ(out.at<float>(0, 1), 10.0F);
  // A block straddling the boundary is dropped, not averaged to 15.
  cv::Mat e(8, 8, CV_32FC1, cv::Scalar(10.0F));
  e.colRange(4, 8).setTo(20.0F);
  disparity_at_level(e, 3, 0.03F, out);  // reads columns 3, 4: 10 and 20
  EXPECT_EQ(out.at<float>(0, 0), 0.0F);
}

// --- the tracker in disparity space -------------------------------------------------------

class DisparityKnownMotion : public ::testing::TestWithParam<int> {};

TEST_P(DisparityKnownMotion, RecoveredFromRenderedPair) {
  const std::vector<SE3> motions = {motion(0.03, 0, 0, 0, 0, 0), motion(0, 0, 0.05, 0, 0, 0),
                                    motion(0, 0, 0, 0, 0, 4), motion(0.02, 0, 0, 0, 3, 0),
                                    motion(0.015, -0.01, 0.02, 1.5, -2.0, 2.5)};
  const SE3& T_ref_cur = motions[static_cast<std::size_t>(GetParam())];
  const RectifiedStereo rig = test_rig();
  const auto room = test::make_room();
  const SE3 T_world_ref = motion(0.05, 0.02, 0, 0, 0, 0);
  const DisparityFrame ref = to_disparity_frame(test::render(room, rig.left(), T_world_ref), rig);
  const DisparityFrame cur =
      to_disparity_frame(test::render(room, rig.left(), T_world_ref * T_ref_cur), rig);
  DirectTracker tracker(rig);
  ASSERT_TRUE(tracker.disparity_input());
  const TrackResult r = tracker.align_pair(ref, cur);
  ASSERT_TRUE(r.ok()) << r.failure_detail;
  EXPECT_LT(test::translation_error_m(r.T_ref_cur, T_ref_cur), 1e-3);
  EXPECT_LT(test::rotation_error_deg(r.T_ref_cur, T_ref_cur), 0.05);
  EXPECT_GT(r.inlier_ratio, 0.6);
}
INSTANTIATE_TEST_SUITE_P(Cases, DisparityKnownMotion, ::testing::Range(0, 5));

TEST(DisparityTracker, SequenceFollowsASmoothMotion) {
  const RectifiedStereo rig = test_rig();
  const auto room = test::make_room();
  DirectTracker tracker(rig);
  double worst_m = 0.0;
  for (int k = 0; k < 15; ++k) {
    const double t = 0.1 * k;
    const SE3 T_world_cam =
        motion(0.1 * std::sin(t), 0.03 * t, 0.15 * t, 2.0 * std::sin(t), 3.0 * t, 0.0);
    const SE3 T_world_first = motion(0, 0, 0, 0, 0, 0);
    const DisparityFrame f = to_disparity_frame(
        test::render(room, rig.left(), T_world_cam, 1'000'000'000LL + k * 100'000'000LL), rig);
    const TrackResult r = tracker.track(f);
    ASSERT_TRUE(r.ok()) << "frame " << k << ": " << r.failure_detail;
    worst_m = std::max(
        worst_m, test::translation_error_m(r.T_world_cam, T_world_first.inverse() * T_world_cam));
  }
  EXPECT_LT(worst_m, 5e-3);
}

// --- bad input ----------------------------------------------------------------------------

template <typename F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(DisparityTracker, BadRigAndOptionsAreClearErrors) {
  RectifiedStereo rig = test_rig();
  rig.baseline_m = 0.0;
  EXPECT_NE(input_error_of([&] { DirectTracker t(rig); }).find("baseline"), std::string::npos);
  rig = test_rig();
  DirectTrackerOptions o;
  o.terms.geometric = GeometricTerm::kAlways;
  EXPECT_NE(input_error_of([&] { DirectTracker t(rig, o); }).find("terms.geometric"),
            std::string::npos);
  o = {};
  o.pyramid.levels = 0;
  EXPECT_NE(input_error_of([&] { DirectTracker t(rig, o); }).find("pyramid.levels"),
            std::string::npos);
}

TEST(DisparityTracker, BadFramesAreReportedNotCrashed) {
  const RectifiedStereo rig = test_rig();
  DirectTracker tracker(rig);
  const DisparityFrame good =
      to_disparity_frame(test::render(test::make_room(), rig.left(), SE3()), rig);
  auto detail_of = [&](const DisparityFrame& f) {
    const TrackResult r = tracker.track(f);
    EXPECT_EQ(r.failure, TrackFailure::kInvalidInput);
    return r.failure_detail;
  };
  DisparityFrame f = good;
  f.disparity_px = cv::Mat();
  EXPECT_NE(detail_of(f).find("empty disparity"), std::string::npos);
  f = good;
  f.disparity_px = cv::Mat(good.disparity_px.size(), CV_8UC1, cv::Scalar(3));
  EXPECT_NE(detail_of(f).find("CV_32FC1"), std::string::npos);
  f = good;
  f.disparity_px = good.disparity_px(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_NE(detail_of(f).find("does not match"), std::string::npos);
  f = good;
  f.image = cv::Mat();
  EXPECT_NE(detail_of(f).find("empty image"), std::string::npos);
  // A depth frame for a disparity tracker, and a disparity frame for a depth tracker.
  const TrackResult r = tracker.track(RgbdFrame{0, good.image, good.disparity_px});
  EXPECT_EQ(r.failure, TrackFailure::kInvalidInput);
  EXPECT_NE(r.failure_detail.find("DisparityFrame"), std::string::npos);
  DirectTracker depth_tracker(rig.left());
  const TrackResult r2 = depth_tracker.track(good);
  EXPECT_EQ(r2.failure, TrackFailure::kInvalidInput);
  EXPECT_NE(r2.failure_detail.find("RgbdFrame"), std::string::npos);
  // No disparity anywhere: too few points, never a crash or a silent success.
  f = good;
  f.disparity_px = cv::Mat(good.disparity_px.size(), CV_32FC1,
                           cv::Scalar(std::numeric_limits<float>::infinity()));
  DirectTracker fresh(rig);
  EXPECT_EQ(fresh.track(f).failure, TrackFailure::kTooFewPoints);
  // The tracker still works after the bad frames.
  DirectTracker again(rig);
  EXPECT_TRUE(again.track(good).ok());
}

}  // namespace
}  // namespace kestrel::odometry
