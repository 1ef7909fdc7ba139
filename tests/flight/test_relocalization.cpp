// The vision's relocalisation after a gap, on the flight's own rendered office frames: the
// first frame after the gap is measured against the last one before it with the true relative
// pose, where the restart alone only clones it.
#include <gtest/gtest.h>

#include <optional>

#include "kestrel/flight/stereo_vision.hpp"
#include "kestrel/sim/scenes.hpp"

namespace kestrel::flight {
namespace {

SE3 offset(double x, double y, double z, double yaw_deg) {
  return SE3(SO3::exp(Eigen::Vector3d(0, 0, yaw_deg * M_PI / 180.0)), Eigen::Vector3d(x, y, z));
}

struct GapRun {
  VisionFrame before, after;
  SE3 T_true;  // the camera at the frame after the gap in the camera at the frame before
};

// A frame at the start pose, then one 2 s later (beyond max_frame_gap_s) from `motion` away
// (body frame: x forward, y left, z up). With `drift`, the vision is given on-board estimates:
// the true pose before the gap, the true pose moved by `drift` after it, with sigma `sigma_m`.
GapRun fly_gap(const StereoVisionOptions& options, const SE3& motion,
               const std::optional<Eigen::Vector3d>& drift = std::nullopt, double sigma_m = 0.1) {
  const sim::Scene scene = sim::make_scene("office", 1);
  StereoVision vision(scene, options, 1);
  const SE3 T_world_a = scene.T_world_start();
  const SE3 T_world_b = T_world_a * motion;
  GapRun run;
  const PoseEstimate estimate_a{T_world_a, 0.01};
  const PoseEstimate estimate_b{
      SE3(T_world_b.so3(), T_world_b.translation() + drift.value_or(Eigen::Vector3d::Zero())),
      sigma_m};
  run.before = vision.process(0, T_world_a, nullptr, drift ? &estimate_a : nullptr);
  run.after = vision.process(2'000'000'000, T_world_b, nullptr, drift ? &estimate_b : nullptr);
  run.T_true = (T_world_a * options.T_body_cam).inverse() * (T_world_b * options.T_body_cam);
  return run;
}

TEST(Relocalization, MeasuresTheMotionAcrossAGapOnRenderedOfficeFrames) {
  // The outage's drift is 20-30 cm: offsets of that size, with some yaw.
  for (const SE3& motion : {offset(0.0, 0.25, 0.0, 0.0), offset(0.05, -0.18, 0.15, 2.0),
                            offset(-0.1, 0.2, -0.12, -3.0)}) {
    const GapRun run = fly_gap(StereoVisionOptions{}, motion);
    ASSERT_TRUE(run.before.track.ok());
    ASSERT_TRUE(run.before.measurement.has_value());
    ASSERT_TRUE(run.after.relocalization.has_value());
    const odometry::RelocalizationResult& r = *run.after.relocalization;
    ASSERT_TRUE(r.ok()) << r.detail;
    ASSERT_TRUE(run.after.measurement.has_value());
    const fusion::RelativePoseMeasurement& m = *run.after.measurement;
    EXPECT_EQ(m.t_ref_ns, 0);  // against the frame before the gap
    EXPECT_EQ(m.t_ns, 2'000'000'000);
    EXPECT_TRUE(m.starts_new_reference);  // the restarted tracker continues from this frame
    const SE3 error = run.T_true.inverse() * m.T_ref_cur;
    // Stereo depth and rendered noise: the odometry's centimetre, not the 20-30 cm offset.
    EXPECT_LT(error.translation().norm(), 0.01) << "inliers " << r.inliers;
    EXPECT_LT(error.so3().log().norm() * 180.0 / M_PI, 0.3);
    EXPECT_TRUE(m.covariance.allFinite());
    // The error is inside the measurement's 3-sigma (its covariance is the tracker's, scaled).
    const Vector6d e = error.log();
    EXPECT_LT((e.transpose() * m.covariance.inverse() * e).value(), 3.0 * 3.0 * 6.0);
  }
}

// With the on-board estimate as the prior (drifted by 20-25 cm, as over a 2 s outage, sigma
// 10 cm): the guided search finds the same answer.
TEST(Relocalization, AGuidedSearchAroundADriftedEstimateFindsTheMotion) {
  const SE3 motion = offset(0.05, -0.18, 0.15, 2.0);
  for (const Eigen::Vector3d& drift :
       {Eigen::Vector3d(0.0, 0.2, -0.1), Eigen::Vector3d(0.1, -0.15, 0.1)}) {
    const GapRun run = fly_gap(StereoVisionOptions{}, motion, drift, 0.1);
    ASSERT_TRUE(run.after.relocalization.has_value());
    const odometry::RelocalizationResult& r = *run.after.relocalization;
    ASSERT_TRUE(r.ok()) << r.detail;
    const SE3 error = run.T_true.inverse() * run.after.measurement->T_ref_cur;
    EXPECT_LT(error.translation().norm(), 0.01) << "inliers " << r.inliers;
    EXPECT_LT(error.so3().log().norm() * 180.0 / M_PI, 0.3);
  }
}

TEST(Relocalization, OffRestartsAsBefore) {
  StereoVisionOptions o;
  o.relocalize_after_gap = false;
  const GapRun run = fly_gap(o, offset(0.0, 0.25, 0.0, 0.0));
  EXPECT_FALSE(run.after.relocalization.has_value());
  ASSERT_TRUE(run.after.measurement.has_value());
  EXPECT_EQ(run.after.measurement->t_ref_ns, run.after.measurement->t_ns);  // clone only
}

TEST(Relocalization, AViewThatSharesNothingFallsBackToTheRestart) {
  // Turned around: the frame after the gap sees the other side of the room.
  const GapRun run = fly_gap(StereoVisionOptions{}, offset(0.0, 0.0, 0.0, 180.0));
  ASSERT_TRUE(run.after.relocalization.has_value());
  EXPECT_FALSE(run.after.relocalization->ok());
  ASSERT_TRUE(run.after.measurement.has_value());
  EXPECT_EQ(run.after.measurement->t_ref_ns, run.after.measurement->t_ns);  // clone only
}

}  // namespace
}  // namespace kestrel::flight
